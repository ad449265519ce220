"""Design algorithms that produce controller artifacts (SOS, LMI, SDRE, periodic, randomized)."""
