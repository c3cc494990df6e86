"""A robot file as the commands load it: the options that shape the chain (method, extras, gravity
override, angle snapping, mimic joints, floating base) and ``load_chain``, which applies them.

Below the stages: the model file (``model/``) records these options and every command loads robots
through ``load_chain``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import cast

from minparam_cli.params import EXTRA_ORDER


@dataclass(frozen=True)
class DeriveOptions:
    """What ``derive`` computes for each robot file: method, extras, gravity override, sampling."""

    method: str = "qr"
    friction: tuple[str, ...] = ()
    rotor_inertia: bool = False
    gravity: tuple[float, float, float] | None = None
    samples: int = 100
    seed: int = 0
    symbolic: bool | None = None  # None (the default): numeric
    snap_angles: float | None = None  # rad: round angles this close to a multiple of 15° (None: never)
    mimic: str = "coupled"  # URDF mimic joints: "coupled" (move with their master) or "fixed" (frozen at their offset)
    floating_base: bool = False  # the URDF's root link is free: six virtual base joints in front of it
    symbolic_numbers: bool = False  # with symbolic: lengths and rational axes as the file's exact numbers


def load_chain(path: str | Path, opts: DeriveOptions, loops: bool = False):
    """Description and chain with the CLI's extras and gravity applied.  A closed chain (``desc.loops``)
    is refused in one line unless the caller handles its loops (``loops``): derive and codegen take the
    spanning tree, simulate, identify and excite add the loops as the coupling (``loops/coupling.py``)."""
    from minparam_cli.chain import build_chain
    from minparam_cli.describe import load_description

    desc = load_description(path, opts.snap_angles, opts.mimic, opts.floating_base)
    if not loops:
        require_open_chain(desc)
    if opts.gravity is not None:
        desc = replace(desc, gravity=cast("tuple[float, float, float]", tuple(opts.gravity)), gravity_source="cli")
    extras: list[tuple[str, ...]] = []
    for j in desc.joints:
        if j.virtual:  # a floating base's coordinates: no friction, rotor or offset
            extras.append(())
            continue
        ex = set(j.extras) | set(opts.friction)
        if opts.rotor_inertia:
            ex.add("rotor_inertia")
        extras.append(tuple(k for k in EXTRA_ORDER if k in ex))
    return desc, build_chain(desc, extras=tuple(extras))


def require_fixed_base(chain, command: str) -> None:
    """One-line refusal for the commands that read or write joint data (identify, simulate): a
    floating base (no base motion columns)."""
    from minparam_cli.errors import UnsupportedError

    if chain.floating_base:
        raise UnsupportedError(f"{command} of floating-base robots needs base motion columns: not supported yet", chain.source)


def require_open_chain(desc) -> None:
    """One-line refusal for the commands that would take a closed chain's spanning tree for the robot."""
    if desc.loops is not None:
        from minparam_cli.errors import UnsupportedError

        raise UnsupportedError("is a closed chain: this command does not read closed chains yet (derive, codegen, "
                               "simulate, identify, evaluate and excite do)", desc.source)
