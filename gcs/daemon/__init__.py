"""The daemon's parts: ingest validation, decision-step assembly, the vehicle registry.

The loop that ties them to Zenoh, MAVLink and the pure tracker step lives in
:mod:`gcs.app`.
"""
