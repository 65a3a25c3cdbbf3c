"""Truth models: the ground target, the vehicles' target sensor, GPS and INS (pure, seeded).

* :mod:`~sim_vehicles.truth.target`: white-noise, street-following and scripted
  targets, and the factory that builds the one a scenario names;
* :mod:`~sim_vehicles.truth.sensor`: range/azimuth/elevation (or bearing-only)
  sensing with range limit, occlusion and constant or zuo2021 eq. (2) noise;
* :mod:`~sim_vehicles.truth.gps`: white noise plus a Gauss-Markov bias, no fix
  inside GPS-denied zones;
* :mod:`~sim_vehicles.truth.ins`: distance and heading-change increments with
  scale error, drift and noise (feng2019 eq. 1).

No I/O (except reading a scripted target's path file when asked), no clock;
randomness only through a ``numpy.random.Generator`` argument. They generate
measurements with this package's own formulas, never with the filters' models,
so one bug cannot hide in both (docs/design.md, the layers).
"""
