"""Multi-target tracking metrics, pure: GOSPA, OSPA and track-level figures over a run.

* :mod:`~gcs.core.metrics.gospa`: generalised OSPA (Rahmathullah, Garcia-Fernandez &
  Svensson 2017) with its localisation / missed / false decomposition;
* :mod:`~gcs.core.metrics.ospa`: OSPA (Schuhmacher, Vo & Vo 2008);
* :mod:`~gcs.core.metrics.track_scores`: track breaks, id swaps, false tracks and
  missed truth-steps over a run, from the per-step GOSPA assignment.

Every metric works on sets of 2-D ENU positions (metres) at one time step; the
assignment is scipy's ``linear_sum_assignment`` on a vectorised distance matrix.
"""

from gcs.core.metrics.gospa import GospaResult, cutoff_distances, gospa
from gcs.core.metrics.ospa import ospa
from gcs.core.metrics.track_scores import StepTracks, TrackScores, track_scores

__all__ = ["GospaResult", "cutoff_distances", "gospa", "ospa", "StepTracks", "TrackScores", "track_scores"]
