"""The options of ``minparam identify`` as one frozen record that checks itself.

``minparam identify`` (cli/identify.py) and ``minparam.identify()`` both build an
:class:`IdentifyOptions` and hand it to ``api.identification.run_identify``: one set of checks, in the
command line's words.  A bad value of an option raises ``OptionError("--flag", detail)`` (the CLI
shows it as click's usage error naming the flag, the API as ``"--flag: detail"``); a bad combination
raises the project's ``InputError`` with the CLI's line.  Either way: exit code 2.

Values may come as the command line's text ("0.6,0.2,0.2", "coulomb,viscous", "t=time,q=pos") or as
Python values (a tuple of floats, a list of kinds, a dict of columns); ``__post_init__`` stores them
normalised (tuples of floats and str, a dict of columns, every effect id when none is given).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from minparam_cli.api.common import OptionError, float_option
from minparam_cli.errors import InputError
from minparam_cli.describe.records import MIMIC_MODES
from minparam_cli.measured.columns import TIME_UNITS as UNIT_SCALES

TIME_UNITS = tuple(UNIT_SCALES)  # the units the readers convert (measured.columns)
PRIORS = ("auto", "nominal", "none")  # auto: nominal when the description has inertials, else none
GEOMETRIES = ("auto", "on", "none")  # auto: the links' ellipsoids when the fit has no prior
SIGMAS = ("hac", "bootstrap", "textbook")
SIDES = ("joint", "motor")
DEFAULT_SPLIT = (0.6, 0.2, 0.2)
MAX_GRAVITY = 1e3  # m/s², 100 g: a larger --gravity is a unit mistake (mm/s²) or a typo
MAX_DECIMATE = 2**31 - 1  # --decimate: one sample in K; a larger K keeps one sample of any recording (and overflows a slice)


def _items(value: str | Iterable[str] | None) -> tuple[str, ...]:
    """"a,b" or ["a", "b"] as ("a", "b"), blanks dropped."""
    if value is None:
        return ()
    items = value.split(",") if isinstance(value, str) else [str(k) for k in value]
    return tuple(k.strip() for k in items if k.strip())


def choice_option(value: Any, allowed: tuple[str, ...], option: str) -> str:
    value = getattr(value, "value", value)  # the CLI's str Enums
    if value not in allowed:
        raise OptionError(option, f"{value!r} is not one of {', '.join(map(repr, allowed))}")
    return str(value)


def _finite_positive(value: float | None) -> bool:
    return value is not None and math.isfinite(value) and value > 0


def _columns(columns: str | Mapping[str, str] | None) -> dict[str, str]:
    from minparam_cli.measured.columns import parse_columns, spec_problem

    if columns is None:
        return {}
    if isinstance(columns, str):
        try:
            return parse_columns(columns)
        except ValueError as e:
            raise OptionError("--columns", str(e)) from None
    out = {str(k): str(v) for k, v in columns.items()}
    for k, v in out.items():
        problem = spec_problem(k, v)
        if problem:
            raise OptionError("--columns", problem)
    return out


def drive_gains_option(value: Any, current: bool) -> tuple[float, ...] | None:
    """``--drive-gains k1,k2,...``: positive joint-side gains (their count is checked against the robot)."""
    if value is None:
        return None
    gains = float_option(value, None, "--drive-gains")
    if not current:
        raise InputError("--drive-gains needs --current: the gains turn current columns into joint torques")
    if not gains or any(g <= 0 for g in gains):
        raise OptionError("--drive-gains", f"expected positive gains, one per joint, got {value!r}")
    return gains


def _mass_bounds(value: Any) -> tuple[tuple[float, float], ...]:
    """--mass-bounds as pairs (lo, hi) kg: "LO,HI" (every link), "LO:HI,LO:HI,..." (one per link), or
    Python pairs; 0 <= LO <= HI, HI may be inf."""
    if value is None or value == "" or value == ():
        return ()
    if isinstance(value, str):
        text = value.replace(" ", "")
        pairs = [p.split(":") for p in text.split(",")] if ":" in text else [text.split(",")]
    else:
        pairs = [list(p) for p in value]
    out = []
    for p in pairs:
        try:
            lo, hi = (float(x) for x in p)
        except (TypeError, ValueError):
            raise OptionError("--mass-bounds", f"expected LO,HI or LO:HI,LO:HI,... in kg, got {value!r}") from None
        if not (math.isfinite(lo) and 0 <= lo <= hi) or math.isnan(hi):
            raise OptionError("--mass-bounds", f"each pair needs 0 <= LO <= HI, got {lo:g}:{hi:g}")
        out.append((lo, hi))
    return tuple(out)


@dataclass(frozen=True)
class IdentifyOptions:
    """Every option of ``minparam identify`` (same names as the flags, same defaults), checked.

    ``robot``: the robot file; ``validate``, ``test``, ``payload_data``: data files or records held in
    memory (see ``minparam.identify``); ``essential``: report the essential parameters, with relative σ
    below ``essential_bound`` %; ``save_model``, ``export_urdf``, ``export_yaml``, ``export_mjcf``: files to write.
    The data to identify from are not an option: ``run_identify(options, data)``."""

    robot: Path
    validate: Any = field(default=None, compare=False)
    test: tuple[Any, ...] = field(default=(), compare=False)
    split: tuple[float, float, float] = DEFAULT_SPLIT
    columns: Mapping[str, str] = field(default_factory=dict)
    time_unit: str = "s"
    topic: str | None = None
    cutoff: float = 5.0
    force_filter: bool = False
    rate: float | None = None
    decimate: int | None = None
    trim_still: float | None = None
    still_speed: float = 0.01
    rest_below_still: bool = True
    friction: tuple[str, ...] = ()
    rotor_inertia: bool = False
    coulomb_smoothing: float = 0.0
    gravity: tuple[float, float, float] | None = None
    effects: tuple[str, ...] = ()  # none given: every effect of the library
    diagnose: bool = True
    min_gain: float = 0.02
    physical: bool = False
    prior: str = "auto"
    prior_weight: float = 1e-2
    geometry: str = "auto"
    mass_bounds: Any = None  # "LO,HI" for every link, "LO:HI,LO:HI,..." one per link, or pairs
    total_mass: float | None = None
    sigma: str = "hac"
    block_length: float | None = None
    replicates: int = 200
    essential: bool = False
    essential_bound: float = 10.0
    ols: bool = False
    seed: int = 0
    mimic: str = "coupled"
    side: str = "joint"
    current: bool = False
    drive_gains: tuple[float, ...] | None = None  # joint-side gains, tau_j = k_j i_j (--current without --side motor)
    payload_data: Any = field(default=None, compare=False)
    payload_mass: float | None = None
    payload_com: tuple[float, float, float] | None = None
    payload_inertia: tuple[float, ...] | None = None
    save_model: Path | None = None
    export_urdf: Path | None = None
    export_yaml: Path | None = None
    export_mjcf: Path | None = None

    def __post_init__(self) -> None:
        from minparam_cli.dynamics.effects import EFFECT_IDS
        from minparam_cli.params import FRICTION_KINDS

        put = self._put
        put("robot", Path(self.robot))
        put("friction", _items(self.friction))
        for k in self.friction:
            if k not in FRICTION_KINDS:
                raise OptionError("--friction", f"unknown friction kind {k!r}")
        put("effects", _items(self.effects) or EFFECT_IDS)
        for k in self.effects:
            if k not in EFFECT_IDS:
                raise OptionError("--effects", f"unknown effect {k!r}; expected any of {','.join(EFFECT_IDS)}")
        shares = float_option(self.split, 3, "--split")
        if any(not (0 <= v <= 1) for v in shares) or shares[0] <= 0 or sum(shares) <= 0:
            raise OptionError("--split", "three shares FIT,SELECTION,TEST in [0, 1], FIT > 0")
        put("split", shares)
        if not _finite_positive(self.cutoff):
            raise OptionError("--cutoff", "must be positive")
        if self.rate is not None and not _finite_positive(self.rate):
            raise OptionError("--rate", "must be positive")
        if self.decimate is not None and not 1 <= self.decimate <= MAX_DECIMATE:  # numpy's slices take a C long
            raise OptionError("--decimate", f"{self.decimate} is not in the range 1<=x<={MAX_DECIMATE}.")
        if self.trim_still is not None and not _finite_positive(self.trim_still):
            raise OptionError("--trim-still", "must be a positive number of seconds")
        if not _finite_positive(self.still_speed):
            raise OptionError("--still-speed", "must be a positive speed")
        if not (math.isfinite(self.min_gain) and 0 <= self.min_gain < 1):
            raise OptionError("--min-gain", "must be in [0, 1)")
        if not (math.isfinite(self.coulomb_smoothing) and self.coulomb_smoothing >= 0):
            raise OptionError("--coulomb-smoothing", "must be a finite velocity >= 0 (0: sign)")
        if not _finite_positive(self.prior_weight):
            raise OptionError("--prior-weight", "must be a positive number")
        put("prior", choice_option(self.prior, PRIORS, "--prior"))
        if self.prior == "nominal" and not self.physical:
            raise OptionError("--prior", "a prior needs --physical")
        self._check_bounds()
        self._check_exports()
        if self.gravity is not None:
            put("gravity", float_option(self.gravity, 3, "--gravity"))
            if math.hypot(*self.gravity) > MAX_GRAVITY:  # 1e308 made the design's columns overflow: an internal error
                raise OptionError("--gravity", f"|g| above {MAX_GRAVITY:g} m/s² ({math.hypot(*self.gravity):.3g}); give it in m/s²")
        if self.seed < 0:
            raise OptionError("--seed", f"{self.seed} is not in the range x>=0.")
        put("time_unit", choice_option(self.time_unit, TIME_UNITS, "--time-unit"))
        put("mimic", choice_option(self.mimic, MIMIC_MODES, "--mimic"))
        put("side", choice_option(self.side, SIDES, "--side"))
        put("test", self._tests(self.test))
        self._check_payload()
        put("drive_gains", drive_gains_option(self.drive_gains, self.current))
        put("columns", _columns(self.columns))
        put("sigma", choice_option(self.sigma, SIGMAS, "--sigma"))
        from minparam_cli.identify.assess.uncertainty import check_options

        check_options(self.uncertainty())
        if not (math.isfinite(self.essential_bound) and self.essential_bound > 0):
            raise InputError(f"--essential-bound {self.essential_bound}: expected a positive percentage")

    def _put(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)  # normalising a frozen record while it is being built

    @staticmethod
    def _tests(test: Any) -> tuple[Any, ...]:
        from minparam_cli.measured.arrays import is_in_memory

        if test is None:
            return ()
        if isinstance(test, (str, Path)) or is_in_memory(test):
            return (test,)
        return tuple(test)

    def _check_bounds(self) -> None:
        """--geometry, --mass-bounds and --total-mass: normalised, and only with --physical."""
        self._put("geometry", choice_option(self.geometry, GEOMETRIES, "--geometry"))
        self._put("mass_bounds", _mass_bounds(self.mass_bounds))
        if self.total_mass is not None:
            if not _finite_positive(self.total_mass):
                raise OptionError("--total-mass", "must be a positive mass (kg)")
            self._put("total_mass", float(self.total_mass))
        for flag, given in (("--mass-bounds", self.mass_bounds), ("--total-mass", self.total_mass is not None),
                            ("--geometry", self.geometry != "auto")):
            if given and not self.physical:
                raise OptionError(flag, "needs --physical")

    def _check_exports(self) -> None:
        """Refuse an export the run cannot make before the fit runs."""
        exports = (("--export-urdf", self.export_urdf), ("--export-yaml", self.export_yaml), ("--export-mjcf", self.export_mjcf))
        for flag, path in exports:
            if path is not None and not self.physical:
                raise InputError(f"{flag} needs --physical: the exported inertias are the bodies of the physical fit")
        self._check_export_paths(exports)
        if self.export_yaml is not None and self.robot.suffix.lower() not in (".yaml", ".yml"):
            raise InputError(f"--export-yaml needs a YAML (DH/MDH) robot; {self.robot} is a URDF, whose joints are not DH rows "
                             "(use --export-urdf)")

    def _check_export_paths(self, exports) -> None:
        """Every export names a regular file (new or existing) in an existing folder, not stdout, and no two
        outputs (with the URDF and MJCF side files FILE.extra.yaml) are the same file."""
        from minparam_cli.model.export_extra import side_path
        from minparam_cli.output import is_stdout, output_target

        seen: dict[str, str] = {}
        if self.save_model is not None and not is_stdout(self.save_model):
            seen[str(output_target(Path(self.save_model))[0].resolve())] = "--save-model"
        for flag, path in exports:
            if path is None:
                continue
            if is_stdout(path):
                raise InputError(f"{flag} -: an export is a file (with its side file beside it); give a file name")
            names = [(flag, Path(path))] + ([(f"{flag}'s side file", Path(side_path(path)))] if flag != "--export-yaml" else [])
            for what, p in names:
                try:
                    target, regular = output_target(p)
                except InputError as e:
                    raise InputError(f"{flag} {e}") from None
                if not regular:
                    raise InputError(f"{flag} {path}: {p} is not a regular file; an export replaces only a regular file")
                key = str(target.resolve())
                if key in seen:
                    raise InputError(f"{flag} {path}: {what} is the same file as {seen[key]}")
                seen[key] = what

    def check_report_path(self, output) -> None:
        """The report (-o) is not one of the files the exports write."""
        from minparam_cli.model.export_extra import side_path
        from minparam_cli.output import is_stdout, output_target

        if output is None or is_stdout(output):
            return
        report = output_target(Path(output))[0].resolve()  # a link loop refused, in one line, before resolve()
        for flag, path in (("--export-urdf", self.export_urdf), ("--export-yaml", self.export_yaml),
                           ("--export-mjcf", self.export_mjcf), ("--save-model", self.save_model)):
            if path is not None and report in (Path(path).resolve(), Path(side_path(path)).resolve()):
                raise InputError(f"-o {output}: is a file {flag} {path} writes; give the report another name")

    def _check_payload(self) -> None:
        """The known payload's options: all need --payload-data, and make a payload (payload.check_spec)."""
        given = (self.payload_mass, self.payload_com, self.payload_inertia)
        if self.payload_data is None:
            if any(v is not None for v in given):
                raise InputError("--payload-mass, --payload-com and --payload-inertia need --payload-data")
            return
        if self.payload_mass is not None:
            self._put("payload_mass", float(self.payload_mass))
        if self.payload_com is not None:
            self._put("payload_com", float_option(self.payload_com, 3, "--payload-com"))
        if self.payload_inertia is not None:
            self._put("payload_inertia", float_option(self.payload_inertia, 6, "--payload-inertia"))
        from minparam_cli.identify.physical.payload import check_spec

        check_spec(self.payload_spec())

    # --- what the stages take -------------------------------------------------------------------

    def payload_spec(self):
        """The known payload (``identify.physical.payload.PayloadSpec``), None without --payload-data."""
        if self.payload_data is None:
            return None
        from minparam_cli.identify.physical.payload import PayloadSpec

        return PayloadSpec(self.payload_mass, self.payload_com, self.payload_inertia)

    def uncertainty(self):
        """--sigma, --block-length, --replicates and --seed as ``UncertaintyOptions``."""
        from minparam_cli.identify.assess.uncertainty import UncertaintyOptions

        return UncertaintyOptions(kind=self.sigma, block_s=None if self.block_length is None else float(self.block_length),
                                  replicates=int(self.replicates), seed=self.seed)

    def load_settings(self):
        """How the robot file becomes the chain, as the model file stores it (``model.file.LoadSettings``)."""
        from minparam_cli.model.file import LoadSettings

        return LoadSettings(friction=self.friction, rotor_inertia=self.rotor_inertia, gravity=self.gravity,
                            coulomb_smoothing=self.coulomb_smoothing, mimic=self.mimic)

    @property
    def nominal_prior(self) -> bool:
        return self.physical and self.prior == "nominal"

    def physical_options(self, chain):
        """--prior (auto resolved: nominal when the description has inertials), --geometry (auto: the
        ellipsoids when there is no prior), --mass-bounds, --total-mass for this chain, as the convex
        fit's options; checked against its links (one-line errors)."""
        from minparam_cli.identify.physical.convex import PhysicalOptions, length_scale
        from minparam_cli.identify.physical.geometry import link_ellipsoids
        from minparam_cli.identify.physical.provenance import check_total_mass, per_link_bounds

        prior = self.prior if self.prior != "auto" else ("nominal" if chain.phi_nominal is not None else "none")
        n = chain.layout.n_inertial // 10
        bounds = per_link_bounds(self.mass_bounds, n) if self.mass_bounds else ()
        check_total_mass(bounds or ((0.0, math.inf),) * n, self.total_mass)
        use = self.geometry == "on" or (self.geometry == "auto" and prior == "none")
        ellipsoids = link_ellipsoids(chain, length_scale(chain))[:n] if use else ()
        return PhysicalOptions(prior=prior, prior_weight=self.prior_weight, mass_bounds=bounds,
                               total_mass=self.total_mass, ellipsoids=ellipsoids)
