"""The co-simulation engine: the fixed-step master, its compiled loop, the FMI host harness, the preflight checks."""
