"""Simulated fixed-wing vehicles, their sensors and the ground target (truth models)."""

__version__ = "0.1.0"
