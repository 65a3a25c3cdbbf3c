"""Pure numerics of the ground station.

Nothing under ``gcs.core`` performs I/O, reads a clock or touches a global random
number generator: time and a ``numpy.random.Generator`` are arguments. It imports
only numpy, scipy, filterpy, the standard library and ``protocols``
(``tests/unit/test_core_purity.py`` enforces this).
"""
