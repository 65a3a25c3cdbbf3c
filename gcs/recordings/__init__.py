"""Recordings: ``gcs record`` (everything on Zenoh to an MCAP file) and ``gcs replay`` (a recording
summarised, processed by the daemon's own engine, shown on the live map, or published again).

The MCAP reading and writing itself is the adapter :mod:`gcs.adapters.recording`.
"""
