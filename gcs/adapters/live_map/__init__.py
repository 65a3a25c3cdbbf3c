"""The live map: the operator's picture built from the wire messages (:mod:`~gcs.adapters.live_map.picture`),
and its outputs, the page's server and Foxglove (:mod:`~gcs.adapters.live_map.outputs`), fed by the daemon and by
``gcs replay --view``."""
