"""twmr-cosim: co-simulation of wheeled mobile robots (engine)."""
__version__ = "0.1.0"
