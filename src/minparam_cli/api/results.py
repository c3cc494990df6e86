"""Typed, frozen result objects of the Python API: the loaded robot and its load options here, the
results of the commands in modules of their own (re-exported below; identify's and evaluate's in
``api/identified.py``).  Every result's ``to_dict()`` is the JSON the command prints, with its
``schema`` key first.  Arrays are numpy arrays, names are tuples of str.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from minparam_cli.api.check_result import CheckResult as CheckResult  # re-exported
from minparam_cli.api.excitation_result import Excitation as Excitation  # re-exported
from minparam_cli.api.generated import GeneratedCode as GeneratedCode  # re-exported
from minparam_cli.api.platform_result import PlatformResult as PlatformResult  # re-exported
from minparam_cli.api.simulation_result import Simulation as Simulation  # re-exported
from minparam_cli.api.singularity import Singularity as Singularity  # re-exported
from minparam_cli.base.result import BaseSet as BaseSet  # re-exported: the one base set

if TYPE_CHECKING:

    from minparam_cli.chain import Chain
    from minparam_cli.describe.records import RobotDescription


@dataclass(frozen=True)
class LoadOptions:
    """How a robot file becomes a chain (the options every command that loads a robot takes)."""

    friction: tuple[str, ...] = ()  # any of "coulomb", "viscous", "offset", added to every joint
    rotor_inertia: bool = False  # a rotor inertia column Ia per joint
    gravity: tuple[float, float, float] | None = None  # m/s², overrides the file
    mimic: str = "coupled"  # URDF mimic joints: "coupled" or "fixed"
    floating_base: bool = False  # the URDF's root link is free
    coulomb_smoothing: float = 0.0  # tanh(dq / V) for sign(dq) in Coulomb columns; 0: sign


@dataclass(frozen=True)
class Robot:
    """A robot loaded from a file (YAML DH/MDH, URDF or MJCF): its chain, ready for every computation.

    ``standard_names``: the standard parameters in column order (XXj XYj XZj YYj YZj ZZj MXj MYj MZj Mj
    per link, then the per-joint extras of ``options``).
    """

    path: Path
    name: str
    dof: int
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    standard_names: tuple[str, ...]
    options: LoadOptions
    chain: Chain = field(repr=False)
    description: RobotDescription = field(repr=False)

    @property
    def nominal_parameters(self):
        """The file's nominal value of each of ``standard_names`` (numpy array): the inertials, then the
        extras (an MJCF's armature, frictionloss, damping; 0 where the file gives none); None when the
        file gives no inertials."""
        import numpy as np

        if self.chain.phi_nominal is None:
            return None
        return np.concatenate([self.chain.phi_nominal, self.chain.nominal_extra_values()])
