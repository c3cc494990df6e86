"""minparam: base inertial parameters, identification and kinematics of robot arms."""

__version__ = "0.1.0"
