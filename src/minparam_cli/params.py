"""Standard parameter names and their order: the one place they are defined.

Khalil's notation, per link j (inertia about the link frame origin, tensor
entries, XY = -sum m x y; first moments m*r):

    XXj XYj XZj YYj YZj ZZj MXj MYj MZj Mj

followed, when enabled, by the per-joint extras in this order:

    Iaj (rotor inertia, Ia*qdd_j)  Fcj (Fc*sign qd_j)  Fvj (Fv*qd_j)  OFFj (constant torque)

Columns are ordered link by link (all 10 inertial parameters of link 1, then
link 2, ...), then the extras joint by joint.  This is the scan order of the
Gautier/Khalil keep rule used by every base-parameter route.
"""

from __future__ import annotations

from dataclasses import dataclass

LINK_PARAMS: tuple[str, ...] = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
N_LINK_PARAMS = len(LINK_PARAMS)

# extra id (as used in descriptions and on the CLI) -> name prefix, in column order
EXTRA_ORDER: tuple[str, ...] = ("rotor_inertia", "coulomb", "viscous", "offset")
EXTRA_PREFIX: dict[str, str] = {"rotor_inertia": "Ia", "coulomb": "Fc", "viscous": "Fv", "offset": "OFF"}
FRICTION_KINDS: tuple[str, ...] = ("coulomb", "viscous", "offset")


@dataclass(frozen=True)
class ParamLayout:
    """Names and column positions of the standard parameters of one chain."""

    n_links: int
    # extras[j] = tuple of extra ids enabled on joint j (0-based), in EXTRA_ORDER
    extras: tuple[tuple[str, ...], ...]

    @property
    def names(self) -> tuple[str, ...]:
        return standard_names(self.n_links, self.extras)

    @property
    def n_inertial(self) -> int:
        return N_LINK_PARAMS * self.n_links

    @property
    def extra_columns(self) -> tuple[tuple[int, str], ...]:
        """(joint index 0-based, extra id) for every extra column, in column order."""
        out = []
        for j, ex in enumerate(self.extras):
            for kind in EXTRA_ORDER:
                if kind in ex:
                    out.append((j, kind))
        return tuple(out)

    @property
    def size(self) -> int:
        return self.n_inertial + len(self.extra_columns)


def link_param_name(kind: str, link: int) -> str:
    """Name of inertial parameter ``kind`` (e.g. 'XX') of link ``link`` (1-based)."""
    return f"{kind}{link}"


def standard_names(n_links: int, extras: tuple[tuple[str, ...], ...] = ()) -> tuple[str, ...]:
    names = [link_param_name(k, j + 1) for j in range(n_links) for k in LINK_PARAMS]
    for j, ex in enumerate(extras):
        for kind in EXTRA_ORDER:
            if kind in ex:
                names.append(f"{EXTRA_PREFIX[kind]}{j + 1}")
    return tuple(names)


def split_name(name: str) -> tuple[str, int]:
    """'MX12' -> ('MX', 12); 'OFF3' -> ('OFF', 3)."""
    i = len(name)
    while i > 0 and name[i - 1].isdigit():
        i -= 1
    if i == len(name) or i == 0:
        raise ValueError(f"not a standard parameter name: {name!r}")
    return name[:i], int(name[i:])
