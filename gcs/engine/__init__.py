"""The engine: the ground station's one loop (acceptance, steps, fusion, planning hand-over, plans
applied, hand-back) as an object fed time-stamped inputs that returns actions (:mod:`gcs.engine.engine`).

The daemon (:mod:`gcs.daemon.app`), ``gcs replay --process`` (:mod:`gcs.recordings.replay`) and the in-process
benches drive it; they differ only in where the inputs come from and where the actions go.
"""
