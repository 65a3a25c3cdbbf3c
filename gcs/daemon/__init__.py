"""The live shell around the engine: the daemon's loop (:mod:`gcs.daemon.app`), its clocks and threads, the
plan runners (a process, a thread or inline: :mod:`gcs.daemon.plan_runners`), the Zenoh router, and the
command lines ``gcs run``, ``gcs demo``, ``gcs status`` and ``gcs router``.

Everything that decides is the engine (:mod:`gcs.engine`); the daemon feeds it from Zenoh and MAVLink
and carries out what it asks.
"""
