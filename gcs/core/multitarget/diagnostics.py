"""What one scan of a many-target tracker did: its counts, the tracks it started, confirmed and deleted."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from gcs.core.multitarget.batches import DetectionBatch
from gcs.core.multitarget.tracks import Advanced, TrackSet

__all__ = ["ScanDiagnostics", "scan_diagnostics"]


@dataclass(frozen=True)
class ScanDiagnostics:
    """Counts of one scan, and the tracks it deleted (status DELETED)."""

    detections: int
    gated: int
    """Detections inside at least one track's gate."""
    associated: int
    unassociated: int
    initiated_ids: tuple[int, ...]
    confirmed_ids: tuple[int, ...]
    deleted: TrackSet
    jpda_clusters: int = 0
    jpda_clusters_over_cap: int = 0
    fusion_fallbacks: int = 0
    pairs_evaluated: int = 0
    """(track, detection) pairs whose innovation was computed, over every vehicle: those that can pass the
    gate (:mod:`~gcs.core.multitarget.candidates`), not every track against every detection."""
    detected_by: Mapping[int, tuple[int, ...]] = field(default_factory=dict)
    """Per vehicle index with detections, the ids of the tracks its association detected
    (:mod:`~gcs.core.multitarget.tracker`'s docstring)."""

    @property
    def initiations(self) -> int:
        return len(self.initiated_ids)

    @property
    def confirmations(self) -> int:
        return len(self.confirmed_ids)

    @property
    def deletions(self) -> int:
        return self.deleted.size


def scan_diagnostics(batches: Sequence[DetectionBatch], counts: Mapping[str, int], advanced: Advanced,
                     born: TrackSet, detected_by: Mapping[int, tuple[int, ...]], fallbacks: int = 0
                     ) -> ScanDiagnostics:
    """The counts of one scan (:class:`ScanDiagnostics`) from what its steps did."""
    total = sum(b.z.shape[0] for b in batches)
    return ScanDiagnostics(
        detections=total, gated=counts["gated"], associated=counts["associated"],
        unassociated=total - counts["associated"], initiated_ids=tuple(born.ids.tolist()),
        confirmed_ids=tuple(advanced.confirmed_ids.tolist()) + tuple(born.confirmed().ids.tolist()),
        deleted=advanced.deleted, jpda_clusters=counts["clusters"], jpda_clusters_over_cap=counts["over"],
        fusion_fallbacks=fallbacks, pairs_evaluated=counts.get("pairs", 0), detected_by=dict(detected_by))
