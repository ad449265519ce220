"""Plant models, the machinery that turns a symbolic model into FMI 2.0 co-simulation FMUs,
the disturbance profiles and the in-process reference loops."""
__version__ = "0.1.0"
