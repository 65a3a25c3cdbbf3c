"""The tracking ground station: the ``gcs`` daemon, its pure core and engine, adapters and shells (the benchmarks
are ``gcs-bench``, the package ``benchmarks``)."""

__version__ = "0.1.0"
