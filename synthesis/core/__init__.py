"""The numerical core of synthesis: polynomials, SOS and LMI programs, conic data, the solve policy, system norms."""
