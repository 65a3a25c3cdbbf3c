"""ArduPilot's real ArduPlane, built for software-in-the-loop (SITL), in the benchmarks and the tests.

The binary is not part of this project (ArduPilot is GPLv3): it is an external program found through
``--sitl PATH`` or the :data:`~benchmarks.sitl.arduplane.SITL_ENV` environment variable, and run as
ArduPilot's own autotest runs it. Everything that talks to it runs in a network namespace of its own
(:mod:`benchmarks.sitl.namespace`).
"""
