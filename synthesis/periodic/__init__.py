"""Periodic stochastic H-infinity state feedback by coupled LMIs (seed 003) and its cubesat instance."""
