"""Many targets: a batched multi-target tracker over identity-free detections.

Every track is filtered at once (:mod:`.filter`, with its per-track oracle
:mod:`.reference`), detections are gated (:mod:`.gating`) and associated per
vehicle by GNN (:mod:`.gnn`) or JPDA (:mod:`.jpda`), the vehicles' information
contributions are summed per track (wang2012 eq. 14-15), and tracks are started
(:mod:`.initiation`), confirmed and deleted (:mod:`.tracks`) by
:class:`~.tracker.MultiTargetTracker`. Equations and sources: docs/multitarget.md.
"""

from gcs.core.multitarget.tracker import MultiTargetState, MultiTargetTracker, ScanDiagnostics
from gcs.core.multitarget.tracks import Lifecycle, TrackSet

__all__ = ["MultiTargetTracker", "MultiTargetState", "ScanDiagnostics", "Lifecycle", "TrackSet"]
