"""The tracking ground station: the ``gcs`` daemon, its pure core, adapters and benchmarks."""

__version__ = "0.1.0"
