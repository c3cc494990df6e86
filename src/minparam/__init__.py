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

The functions and result types are imported on first use (PEP 562): ``import minparam`` loads only
the error classes, so it costs no more than the command line's own start-up
(benchmarks/bench_startup.py).
"""

from typing import TYPE_CHECKING, Any

from minparam_cli import __version__
from minparam_cli.errors import (
    ComputationError,
    DataError,
    DescriptionError,
    InputError,
    MinparamError,
    MinparamWarning,
    UnsupportedError,
)

# public name -> the module that defines it (imported on first access)
_LAZY = {
    "excite": "minparam_cli.api.excitation",
    "codegen": "minparam_cli.api.generation",
    "evaluate": "minparam_cli.api.evaluation",
    "identify": "minparam_cli.api.identification",
    "Errors": "minparam_cli.api.identified",
    "Evaluation": "minparam_cli.api.identified",
    "Identification": "minparam_cli.api.identified",
    "Model": "minparam_cli.api.identified",
    "singular": "minparam_cli.api.kinematics",
    "platform_fk": "minparam_cli.api.platform",
    "platform_ik": "minparam_cli.api.platform",
    "platform_workspace": "minparam_cli.api.platform",
    **dict.fromkeys(("BaseSet", "CheckResult", "Excitation", "GeneratedCode", "LoadOptions", "PlatformResult", "Robot",
                     "Simulation", "Singularity"), "minparam_cli.api.results"),
    **dict.fromkeys(("check", "derive", "load_robot", "regressor"), "minparam_cli.api.robot"),
    "simulate": "minparam_cli.api.simulation",
}

if TYPE_CHECKING:  # what type checkers and editors see: the same names, imported eagerly
    from minparam_cli.api.evaluation import evaluate
    from minparam_cli.api.excitation import excite
    from minparam_cli.api.generation import codegen
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


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'minparam' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

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
