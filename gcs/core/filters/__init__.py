"""Filters: unscented transform, unscented information filter and DUIF fusion.

Filters hold parameters, never the estimate: every function takes an estimate
and returns a new one.
"""
