"""minparam: base inertial parameters, identification and kinematics of robot arms, from Python.

The public face of the package: every capability of the ``minparam`` command is one function call
away, numpy arrays in, typed frozen results out, and ``result.to_dict()`` is exactly the JSON the
command prints for the same call.  Nothing here prints or exits; errors are ``MinparamError``
subclasses with the command's one-line message, notes are ``MinparamWarning`` warnings.

>>> import minparam
>>> robot = minparam.load_robot("robots/planar2r.yaml")
>>> minparam.derive(robot).names
('ZZR1', 'MXR1', 'MY1', 'ZZR2', 'MXR2', 'MY2')

This package holds re-exports and documentation only; the implementation lives in
``minparam_cli`` (``minparam_cli.api`` and the stages it calls).  See docs/api.md.
"""

from minparam_cli import __version__
from minparam_cli.api.excitation import excite
from minparam_cli.api.generation import codegen
from minparam_cli.api.evaluation import evaluate
from minparam_cli.api.identification import identify
from minparam_cli.api.identified import Errors, Evaluation, Identification, Model
from minparam_cli.api.kinematics import singular
from minparam_cli.api.platform import platform_fk, platform_ik, platform_workspace
from minparam_cli.api.results import (
    BaseSet,
    CheckResult,
    Excitation,
    GeneratedCode,
    LoadOptions,
    PlatformResult,
    Robot,
    Simulation,
    Singularity,
)
from minparam_cli.api.robot import check, derive, load_robot, regressor
from minparam_cli.api.simulation import simulate
from minparam_cli.errors import (
    ComputationError,
    DataError,
    DescriptionError,
    InputError,
    MinparamError,
    MinparamWarning,
    UnsupportedError,
)

__all__ = [
    "__version__",
    # functions
    "load_robot",
    "check",
    "derive",
    "regressor",
    "identify",
    "evaluate",
    "simulate",
    "excite",
    "codegen",
    "singular",
    "platform_ik",
    "platform_fk",
    "platform_workspace",
    # results
    "Robot",
    "LoadOptions",
    "CheckResult",
    "BaseSet",
    "Identification",
    "Errors",
    "Model",
    "Evaluation",
    "Simulation",
    "Excitation",
    "GeneratedCode",
    "Singularity",
    "PlatformResult",
    # errors and warnings
    "MinparamError",
    "InputError",
    "DescriptionError",
    "DataError",
    "UnsupportedError",
    "ComputationError",
    "MinparamWarning",
]
