"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""

PLANNERS = ("ga_k5", "ga_k0", "orbit", "pursuit")
"""Planners of ``gcs bench urban``: GA-RHC on k+5 predictions or on the current
estimate (k+0, the paper's comparison), stand-off orbit, straight-line pursuit."""
