"""Default settings of the kinematics stages, importable without numpy (the CLI shows them in --help)."""

PLATFORM_FK_METHODS = ("auto", "exact", "pso", "multistart")
"""Forward kinematics of a platform: the methods ``platform fk --method`` accepts."""

DEFAULT_EPSILON = 1e-3
"""Relative cut on σ_min/σ_max of the normalised screw matrix."""

DEFAULT_DAMPING = 0.05
"""Damping of the damped-least-squares comparison, relative to σ_max."""

DEFAULT_STEP_DEG = 15.0
"""Grid step of the global scan, degrees."""
