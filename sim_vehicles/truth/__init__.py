"""Truth models: the ground target and the vehicles' target sensor (pure, seeded).

They generate measurements with this package's own formulas, never with the
filters' models, so one bug cannot hide in both (design.md section 2).
"""
