"""Several ground stations as one: fusing members' tracks, one global id per target, who plans for what.

* :mod:`~gcs.core.federation.fusion`: covariance intersection (and the information sum it is measured against);
* :mod:`~gcs.core.federation.global_ids`: the rules by which every member names its tracks alike;
* :mod:`~gcs.core.federation.picture`: a member's picture of every target, held or lost;
* :mod:`~gcs.core.federation.coordination`: which targets a member's team plans for.
"""

from gcs.core.federation.coordination import Claim, Team, claims
from gcs.core.federation.fusion import FUSION_RULES, covariance_intersection, independent_fusion
from gcs.core.federation.global_ids import GlobalName, GlobalNames
from gcs.core.federation.picture import FederatedPicture, GlobalTarget, OwnTracks, Picture

__all__ = ["Claim", "Team", "claims", "FUSION_RULES", "covariance_intersection", "independent_fusion", "GlobalName",
           "GlobalNames", "FederatedPicture", "GlobalTarget", "OwnTracks", "Picture"]
