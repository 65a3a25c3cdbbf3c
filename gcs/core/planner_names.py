"""The names of the planners, one scheme for the scenarios (``[planner] kind``) and the command line
(``gcs run --planner``, ``gcs-bench``): what a user types.

The planners themselves are :mod:`gcs.core.planners` (:data:`gcs.core.planners.PLANNER_CLASSES` maps each name
to the class that plans); the tracker a scenario describes is built with one by
:func:`gcs.engine.tracker_factory.tracker_config`. This module holds strings alone, so that the scenario model
(:mod:`gcs.config`) checks a name without loading NumPy.

``sight`` (the default)
    The probability that at least one UAV sees the target over its predicted distribution, searched vehicle
    by vehicle (:class:`~gcs.core.planners.SightPlanner`) on the k+1..k+n predictions; ``sight_k0`` on the
    current estimate held over the horizon.
``sight_cem``, ``sight_ga``
    The same objective searched otherwise: cross-entropy over whole-team plans, and wang2012's GA operators
    (:mod:`gcs.core.planners.cross_entropy`).
``ga_k5``, ``ga_k0``
    wang2012 section 4: the GA receding-horizon planner (RHC cost eq. 20-26, GA eq. 27-29) on the k+5
    predictions, or on the current estimate (k+0, the paper's comparison).
``orbit``, ``pursuit``
    Baselines: a stand-off orbit of the estimate, straight-line pursuit.
``gcrlb_lm``, ``crlb_lm``, ``straight``
    zuo2021 section 4: the GCRLB heading planner (penalty + Levenberg-Marquardt), Dogancay's constant-noise
    CRLB planner, and straight flight at the target.
"""

from __future__ import annotations

__all__ = ["DEFAULT_PLANNER", "URBAN_PLANNERS", "SEARCH_VARIANTS", "SIGHT_PLANNERS", "K0_PLANNERS", "GA_PLANNERS",
           "AOA_PLANNERS", "MULTITARGET_PLANNERS", "PLANNERS"]

DEFAULT_PLANNER = "sight"
URBAN_PLANNERS = ("sight", "sight_k0", "ga_k5", "ga_k0", "orbit", "pursuit")
"""The planners of the city (``gcs-bench urban`` runs these by default)."""
SEARCH_VARIANTS = ("sight_cem", "sight_ga")
"""The sight objective searched otherwise, to compare searches."""
SIGHT_PLANNERS = ("sight", "sight_k0") + SEARCH_VARIANTS
"""Planners of the sight objective (:mod:`gcs.core.planners.sight`)."""
K0_PLANNERS = ("sight_k0", "ga_k0")
"""Planners that plan on the current estimate held over the horizon."""
GA_PLANNERS = ("ga_k5", "ga_k0")
"""wang2012's GA-RHC, which plans the paper's ``n`` steps ahead (``[planner] horizon_steps``)."""
AOA_PLANNERS = ("gcrlb_lm", "crlb_lm", "straight")
"""zuo2021's heading planners for bearing-only sensors."""
MULTITARGET_PLANNERS = ("sight", "sight_k0")
"""The planners that share the UAVs between several targets (a scenario's ``[multitarget]``)."""
PLANNERS = URBAN_PLANNERS + SEARCH_VARIANTS + AOA_PLANNERS
"""Every planner a scenario or ``gcs run --planner`` may name."""
