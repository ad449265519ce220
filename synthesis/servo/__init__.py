"""The VSCMG's SDRE servo (seed 002): checked gains, their polynomial fit, the SOS stability region."""
