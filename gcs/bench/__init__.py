"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""
