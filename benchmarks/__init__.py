"""Benchmarks outside the runtime package: measurements that choose designs, run as ``python -m benchmarks...``."""
