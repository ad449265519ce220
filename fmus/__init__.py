"""Plant models and the machinery that turns a symbolic model into FMI 2.0 co-simulation FMUs."""
__version__ = "0.1.0"
