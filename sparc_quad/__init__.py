"""sparc-quad: the SPARC spine integrated into a simulated quadruped, with the paper's experiments."""

__version__ = "0.1.0"
