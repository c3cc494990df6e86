"""``minparam codegen``'s options."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.api.common import OptionError, choice_option, float_option, friction_option
from minparam_cli.api.options.derive import METHODS
from minparam_cli.errors import InputError
from minparam_cli.describe.records import MIMIC_MODES

LANGS = ("c", "python", "casadi")
PARAMETERS = ("physical", "fit")


def number_text(value: float) -> str:
    """A number as the command line would spell it: %g when that is exact, else repr."""
    return repr(value) if float(format(value, "g")) != value else format(value, "g")


@dataclass(frozen=True)
class CodegenOptions:
    """The options of ``minparam codegen`` / ``minparam.codegen``, checked on construction.

    ``friction`` and ``gravity`` keep the command line's text ("coulomb,viscous", "0,0,-9.81"; a
    sequence from Python is written as that text): the generated file's comment block shows them as
    given.  ``friction_kinds`` and ``gravity_vector`` are their values."""

    lang: str
    output: Path | None = None  # the file the code is meant for (names the C header and identifiers)
    model: Path | None = None  # a model file of identify --save-model: also inverse_dynamics
    parameters: str | None = None  # with model: "physical" or "fit"
    full: bool = False  # also the full regressor and K
    name: str | None = None  # prefix of the C identifiers
    method: str = "qr"
    friction: str = ""
    rotor_inertia: bool = False
    gravity: str | None = None
    samples: int = 100
    seed: int = 0
    mimic: str = "coupled"
    floating_base: bool = False

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        put(self, "lang", choice_option(self.lang, LANGS, "--lang"))
        put(self, "method", choice_option(self.method, METHODS, "--method"))
        put(self, "mimic", choice_option(self.mimic, MIMIC_MODES, "--mimic"))
        if self.parameters is not None:
            put(self, "parameters", choice_option(self.parameters, PARAMETERS, "--parameters"))
        friction = self.friction if isinstance(self.friction, str) else ",".join(str(k) for k in (self.friction or ()))
        friction_option(friction)
        put(self, "friction", friction)
        if self.samples < 1:
            raise OptionError("--samples", "must be positive")
        if self.gravity is not None:
            g = float_option(self.gravity, 3, "--gravity")
            if not isinstance(self.gravity, str):
                put(self, "gravity", ",".join(number_text(x) for x in g))
        if self.model is None and self.parameters is not None:
            raise InputError("--parameters needs --model")
        if self.model is not None:
            given = [flag for flag, on in (("--friction", self.friction_kinds), ("--rotor-inertia", self.rotor_inertia),
                                           ("--gravity", self.gravity is not None), ("--method projection", self.method != "qr"),
                                           ("--floating-base", self.floating_base)) if on]
            if given:
                raise InputError(f"{' and '.join(given)}: with --model the model's own settings apply")
        if self.name is not None:
            from minparam_cli.codegen.functions import identifier

            prefix = identifier(self.name)
            if prefix != self.name:
                raise OptionError("--name", f"must be a C identifier (letters, digits, _), e.g. {prefix}")
        if self.model is not None and not isinstance(self.model, (str, Path)):
            raise InputError(f"model: expected a model file path (of identify --save-model or Model.save), got {type(self.model).__name__}")
        for key in ("output", "model"):
            value = getattr(self, key)
            if value is not None:
                put(self, key, Path(value))
        put(self, "full", bool(self.full))
        put(self, "rotor_inertia", bool(self.rotor_inertia))
        put(self, "floating_base", bool(self.floating_base))

    @property
    def friction_kinds(self) -> tuple[str, ...]:
        return friction_option(self.friction)

    @property
    def gravity_vector(self) -> tuple[float, float, float] | None:
        if self.gravity is None:
            return None
        g = float_option(self.gravity, 3, "--gravity")
        return (g[0], g[1], g[2])

    def command_line(self, robot: Any) -> str:
        """The command line as the comment block shows it (the options that were given)."""
        parts = ["minparam codegen", str(robot), "--lang", self.lang]
        if self.output is not None:
            parts += ["-o", str(self.output)]
        for flag, value, default in (("--model", self.model, None), ("--parameters", self.parameters, None),
                                     ("--name", self.name, None), ("--method", self.method, "qr"),
                                     ("--friction", self.friction, ""), ("--gravity", self.gravity, None),
                                     ("--samples", self.samples, 100), ("--seed", self.seed, 0),
                                     ("--mimic", self.mimic, "coupled")):
            if value != default:
                parts += [flag, str(value)]
        parts += [flag for flag, on in (("--rotor-inertia", self.rotor_inertia), ("--full", self.full),
                                        ("--floating-base", self.floating_base)) if on]
        return " ".join(parts)
