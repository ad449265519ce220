"""Polynomial state feedback of the MRP satellite by SOS: H-infinity (seed 000), mixed H2/H-infinity
(seed 001), L2 gains.
"""
