"""The daemon's parts: ingest validation, decision-step assembly, the vehicle registry, fusion, planning.

The engine that ties them into the ground station's decisions is :mod:`gcs.engine`; the
shell that feeds it from Zenoh and MAVLink is :mod:`gcs.app`.
"""
