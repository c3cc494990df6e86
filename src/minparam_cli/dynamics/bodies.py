"""Are a description's nominal inertial values real bodies?

A link's mass m, centre of mass c and inertia about the centre of mass I_C
describe a rigid body exactly when its pseudo-inertia matrix is positive
semidefinite (Wensing, Kim and Slotine, IEEE RA-L 3(1), 2018; the matrix is
``minparam_cli.dynamics.inertia.pseudo_inertia_from_standard``): m > 0 and the principal
moments of I_C obey the triangle inequalities J_a + J_b >= J_c (which make
them non-negative).  Equality is a flat plate, a rod or a point mass: the
limit of real bodies, accepted.  A link with no mass and no inertia is a
massless link, accepted.

derive does not use these values (a one-line warning); check gives a verdict
per link; simulate and ``identify --physical --prior nominal`` refuse a
description whose bodies are impossible.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.describe.records import RobotDescription

# a violation must exceed this share of the body's size (trace of its second moments) to count,
# so that a flat body written with rounded decimals is not refused
RELATIVE_TOL = 1e-9


def link_problem(phi_link) -> str | None:
    """None for a real (or massless) body, else what is wrong, from the 10 standard parameters
    (params.LINK_PARAMS: inertia about the link frame origin, first moments m·c, mass)."""
    from minparam_cli.dynamics.inertia import pseudo_inertia_from_standard

    phi = np.asarray(phi_link, dtype=float)
    if not np.all(np.isfinite(phi)):
        return "inertial values are not finite"
    if not np.any(phi):
        return None  # a massless link
    J = pseudo_inertia_from_standard(phi)
    m, h = J[3, 3], J[:3, 3]
    if not m > 0:
        return f"mass {m:g} kg is not positive"
    sigma = J[:3, :3] - np.outer(h, h) / m  # second moments of the mass about the centre of mass
    eig = np.linalg.eigvalsh(0.5 * (sigma + sigma.T))
    size = max(float(np.abs(eig).sum()), np.finfo(float).tiny)
    if eig[0] >= -RELATIVE_TOL * size:
        return None
    moments = np.sort(np.trace(sigma) - eig)  # principal moments of inertia about the centre of mass
    if moments[0] < 0:
        return f"principal moments of inertia about the centre of mass {_fmt(moments)} kg·m²: one is negative"
    return (f"principal moments of inertia about the centre of mass {_fmt(moments)} kg·m² violate the triangle "
            f"inequality ({moments[0]:.4g} + {moments[1]:.4g} < {moments[2]:.4g})")


def _fmt(values) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"


def body_verdicts(desc: RobotDescription) -> list[tuple[str, str | None]]:
    """(link name, problem or None) for every moving link with inertial values, in joint order."""
    from minparam_cli.dynamics.inertia import standard_from_com

    out: list[tuple[str, str | None]] = []
    for k, jr in enumerate(desc.joints):
        if jr.inertial is None or jr.massless:
            continue
        ine = jr.inertial
        values = [ine.mass, *ine.com, *ine.inertia]
        if not np.all(np.isfinite(values)):
            out.append((jr.link_name or f"link{k + 1}", "inertial values are not finite"))
            continue
        ixx, ixy, ixz, iyy, iyz, izz = ine.inertia
        Ic = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]
        out.append((jr.link_name or f"link{k + 1}", link_problem(standard_from_com(ine.mass, ine.com, Ic))))
    return out


def body_problems(desc: RobotDescription) -> list[tuple[str, str]]:
    """(link, problem) for every link whose nominal values are not a real body."""
    return [(link, problem) for link, problem in body_verdicts(desc) if problem is not None]


def problems_text(desc: RobotDescription, problems: list[tuple[str, str]], shown: int = 2) -> str:
    """One line naming the file and the impossible links (the first ``shown`` with their reason)."""
    return nominal_problems_text(desc.source, problems, shown)


def nominal_problems(chain) -> list[tuple[str, str]]:
    """(link, problem) for every link of ``chain`` whose nominal standard parameters
    (``chain.phi_nominal``, lumped and in the link frame) are not a real body; [] without them."""
    from minparam_cli.params import N_LINK_PARAMS

    if chain.phi_nominal is None:
        return []
    phi = np.asarray(chain.phi_nominal, dtype=float)
    out = []
    for k in range(chain.n):
        problem = link_problem(phi[N_LINK_PARAMS * k : N_LINK_PARAMS * (k + 1)])
        if problem is not None:
            out.append((chain.link_names[k] or f"link{k + 1}", problem))
    return out


def nominal_problems_text(source: str, problems: list[tuple[str, str]], shown: int = 2) -> str:
    """One line naming the file and its impossible links (the first ``shown`` with their reason)."""
    parts = [f"{link}: {problem}" for link, problem in problems[:shown]]
    more = f"; and {len(problems) - shown} more" if len(problems) > shown else ""
    links = "link" if len(problems) == 1 else "links"
    return f"{source}: nominal inertial values of {len(problems)} {links} are not a real body ({'; '.join(parts)}{more})"
