"""The engine: the ground station's one loop (acceptance, steps, fusion, planning hand-over, plans
applied, hand-back) as an object fed time-stamped inputs that returns actions (:mod:`gcs.engine.engine`).

The daemon (:mod:`gcs.daemon.app`), ``gcs replay --process`` (:mod:`gcs.recordings.replay`) and the
in-process benches drive it; they differ only in where the inputs come from and where the actions go.
It reads no clock, starts no thread and opens no socket: time comes in its inputs
(:mod:`gcs.engine.events`), and importing it loads nothing of the adapters or the shells
(``tests/unit/test_core_purity.py``, ``tests/unit/test_layers.py``).

Its parts: :mod:`~gcs.engine.acceptance` (with :mod:`~gcs.engine.ingest`, :mod:`~gcs.engine.registry`,
:mod:`~gcs.engine.steps` and :mod:`~gcs.engine.navigation`), :mod:`~gcs.engine.fusion` and
:mod:`~gcs.engine.multitarget` (the trackers' scans), :mod:`~gcs.engine.hand_over` and
:mod:`~gcs.engine.plan_jobs` (what is planned and what a plan does), :mod:`~gcs.engine.memory`,
:mod:`~gcs.engine.records`, and :mod:`~gcs.engine.tracker_factory` (the tracker a scenario describes).
"""
