"""Robust state feedback over real parametric uncertainty by LMIs, randomized analysis, and the DEMETER
designs (seed 004).
"""
