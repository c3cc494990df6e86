"""Standard parameter names and their order: the one place they are defined.

Khalil's notation, per link j (inertia about the link frame origin, tensor
entries, XY = -sum m x y; first moments m*r):

    XXj XYj XZj YYj YZj ZZj MXj MYj MZj Mj

followed, when enabled, by the per-joint extras in this order:

    Iaj (rotor inertia, Ia*qdd_j)  Fcj (Fc*sign qd_j)  Fvj (Fv*qd_j)  OFFj (constant torque)

and, with a declared transmission (theta_m = N q), the motor-side extras of motor k, numbered
like the joint of the same row of N (docs/methods/transmission.md):

    Iamk (Nᵀe_k (N qdd)_k)  Fcmk (Nᵀe_k sign (N qd)_k)  Fvmk (Nᵀe_k (N qd)_k)

Columns are ordered link by link (all 10 inertial parameters of link 1, then
link 2, ...), then the extras joint by joint.  This is the scan order of the
Gautier/Khalil keep rule used by every base-parameter route.

A floating base is six virtual joints (``describe/urdf_tree.py``) whose first five
links have no mass and no columns; the sixth carries the free link, numbered 0
as in Khalil's floating-base notation (XX0 ... M0), the robot's joints 1..n.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

LINK_PARAMS: tuple[str, ...] = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
N_LINK_PARAMS = len(LINK_PARAMS)

# extra id (as used in descriptions and on the CLI) -> name prefix, in column order
# motor-side extras (a declared transmission, dynamics/transmission.py) are numbered by motor, after
# the joint extras of the joint with the same number: Iamk (motor rotor inertia), Fcmk, Fvmk (motor friction)
MOTOR_KINDS: tuple[str, ...] = ("motor_inertia", "motor_coulomb", "motor_viscous")
MOTOR_FRICTION_KINDS: dict[str, str] = {"coulomb": "motor_coulomb", "viscous": "motor_viscous"}
EXTRA_ORDER: tuple[str, ...] = ("rotor_inertia", "coulomb", "viscous", "offset") + MOTOR_KINDS
EXTRA_PREFIX: dict[str, str] = {"rotor_inertia": "Ia", "coulomb": "Fc", "viscous": "Fv", "offset": "OFF",
                                "motor_inertia": "Iam", "motor_coulomb": "Fcm", "motor_viscous": "Fvm"}
FRICTION_KINDS: tuple[str, ...] = ("coulomb", "viscous", "offset")


@dataclass(frozen=True)
class ParamLayout:
    """Names and column positions of the standard parameters of one chain."""

    n_links: int
    # extras[j] = tuple of extra ids enabled on joint j (0-based), in EXTRA_ORDER
    extras: tuple[tuple[str, ...], ...]
    # the number each link (and its joint) has in the names, None for a massless virtual link
    # without columns; None: links 1..n_links
    numbers: tuple[int | None, ...] | None = None
    # chain indices of links that keep their number (their joint's extras are named by it) but have no
    # inertial columns: MJCF's massless frames between the joints of one body
    massless: tuple[int, ...] = ()

    @cached_property
    def link_numbers(self) -> tuple[int | None, ...]:
        return tuple(range(1, self.n_links + 1)) if self.numbers is None else self.numbers

    @cached_property
    def links_with_columns(self) -> tuple[int, ...]:
        """Chain indices of the links that have inertial columns, in column order (10 each)."""
        return tuple(j for j, k in enumerate(self.link_numbers) if k is not None and j not in self.massless)

    @cached_property
    def inertial_columns(self) -> tuple[int, ...]:
        """Positions of the inertial columns among 10 per link of the chain (every link having 10)."""
        return tuple(N_LINK_PARAMS * j + i for j in self.links_with_columns for i in range(N_LINK_PARAMS))

    @cached_property
    def names(self) -> tuple[str, ...]:
        return standard_names(self.n_links, self.extras, self.numbers, self.massless)

    @cached_property
    def n_inertial(self) -> int:
        return N_LINK_PARAMS * len(self.links_with_columns)

    @cached_property
    def extra_columns(self) -> tuple[tuple[int, str], ...]:
        """(joint index 0-based, extra id) for every extra column, in column order."""
        out = []
        for j, ex in enumerate(self.extras):
            for kind in EXTRA_ORDER:
                if kind in ex:
                    out.append((j, kind))
        return tuple(out)

    @cached_property
    def size(self) -> int:
        return self.n_inertial + len(self.extra_columns)


def link_param_name(kind: str, link: int) -> str:
    """Name of inertial parameter ``kind`` (e.g. 'XX') of link ``link`` (1-based)."""
    return f"{kind}{link}"


def standard_names(n_links: int, extras: tuple[tuple[str, ...], ...] = (), numbers: tuple[int | None, ...] | None = None,
                   massless: tuple[int, ...] = ()) -> tuple[str, ...]:
    numbers = tuple(range(1, n_links + 1)) if numbers is None else numbers
    names = [link_param_name(k, number) for j, number in enumerate(numbers) if number is not None and j not in massless for k in LINK_PARAMS]
    for j, ex in enumerate(extras):
        for kind in EXTRA_ORDER:
            if kind in ex:
                names.append(f"{EXTRA_PREFIX[kind]}{numbers[j]}")
    return tuple(names)


def split_name(name: str) -> tuple[str, int]:
    """'MX12' -> ('MX', 12); 'OFF3' -> ('OFF', 3)."""
    i = len(name)
    while i > 0 and name[i - 1].isdigit():
        i -= 1
    if i == len(name) or i == 0:
        raise ValueError(f"not a standard parameter name: {name!r}")
    return name[:i], int(name[i:])


def latex_name(name: str) -> str:
    """'XXR2' -> '\\mathrm{XX}^{R}_{2}', 'Ia3' -> '\\mathrm{Ia}_{3}'."""
    kind, link = split_name(name)
    sup = ""
    if kind.endswith("R") and kind not in ("R",):
        plain = kind[:-1]
        if plain in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "Ia", "Fc", "Fv", "OFF"):
            kind, sup = plain, "^{R}"
    return rf"\mathrm{{{kind}}}{sup}_{{{link}}}"
