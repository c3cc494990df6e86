"""Random physically consistent inertial parameters, and the test for consistency.

A link's 10 standard parameters (``params.LINK_PARAMS``: XX XY XZ YY YZ ZZ
about the link frame origin, MX MY MZ = m·c, M = m) belong to a real body
exactly when its pseudo-inertia matrix

    J = [[Σ, h], [hᵀ, m]],   Σ = ½ tr(I_O)·1 − I_O,   h = m·c,

is positive definite (Wensing, Kim and Slotine, "Linear matrix inequalities
for physically consistent inertial parameter identification: a statistical
perspective on the mass distribution", IEEE RA-L 3(1), 2018).  J ≻ 0 is the
same as: m > 0, and the inertia about the centre of mass positive definite
with principal moments obeying the triangle inequality J_a + J_b > J_c.
Sousa and Cortesão ("Physical feasibility of robot base inertial parameter
identification: a linear matrix inequality approach", IJRR 33(6), 2014)
wrote the weaker conditions m > 0, I_C ≻ 0 as linear matrix inequalities;
the triangle inequality is what Wensing et al. add.

The sampler draws a body as a mass with positive second moments of its mass
distribution along three random principal axes, which gives principal moments
J_x = m(σ_y² + σ_z²) etc. and hence the strict triangle inequality
(J_x + J_y − J_z = 2 m σ_z² > 0) by construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.params import LINK_PARAMS, N_LINK_PARAMS

# Mass range of the sampler, kg (log-uniform).
MASS_RANGE = (0.5, 10.0)
# Centre of mass uniform in a cube of edge length_scale centred on the link frame origin.
COM_BOX_FRACTION = 0.5
# Standard deviations of the mass distribution along its principal axes, as fractions of length_scale.
SPREAD_RANGE = (0.05, 0.3)


@dataclass(frozen=True, eq=False)
class RandomInertia:
    """Sampled bodies, one per link, and their standard parameters."""

    mass: np.ndarray  # (n,) kg
    com: np.ndarray  # (n, 3) m, in the link frame
    inertia_com: np.ndarray  # (n, 3, 3) kg·m², about the centre of mass, link-frame axes
    phi: np.ndarray  # (10 n,) standard parameters in params.LINK_PARAMS order
    length_scale: float  # m, the size of the box the CoM was drawn in


def standard_from_com(mass: float, com, inertia_com) -> np.ndarray:
    """Mass, CoM c and inertia about the CoM -> the 10 standard parameters about the frame origin.

    Parallel-axis (Huygens–Steiner) theorem: I_O = I_C + m (cᵀc·1 − c cᵀ); first moments m·c.
    """
    c = np.asarray(com, dtype=float).reshape(3)
    Ic = np.asarray(inertia_com, dtype=float).reshape(3, 3)
    Io = Ic + mass * (c @ c * np.eye(3) - np.outer(c, c))
    values = {
        "XX": Io[0, 0], "XY": Io[0, 1], "XZ": Io[0, 2], "YY": Io[1, 1], "YZ": Io[1, 2], "ZZ": Io[2, 2],
        "MX": mass * c[0], "MY": mass * c[1], "MZ": mass * c[2], "M": mass,
    }
    return np.array([values[k] for k in LINK_PARAMS], dtype=float)


def body_from_standard(phi_link) -> tuple[float, np.ndarray, np.ndarray]:
    """The 10 standard parameters of one link -> (mass, centre of mass, inertia about it), the inverse of
    ``standard_from_com`` (same frame).  A mass that is not positive has no centre of mass: NaN, and the
    inertia about the frame origin."""
    p = dict(zip(LINK_PARAMS, np.asarray(phi_link, dtype=float).reshape(N_LINK_PARAMS), strict=True))
    m = float(p["M"])
    Io = np.array([[p["XX"], p["XY"], p["XZ"]], [p["XY"], p["YY"], p["YZ"]], [p["XZ"], p["YZ"], p["ZZ"]]])
    if not m > 0:
        return m, np.full(3, np.nan), Io
    c = np.array([p["MX"], p["MY"], p["MZ"]]) / m
    return m, c, Io - m * (c @ c * np.eye(3) - np.outer(c, c))


def pseudo_inertia_from_standard(phi_link) -> np.ndarray:
    """The 4x4 pseudo-inertia matrix J of one link (Wensing et al. 2018) from its 10 parameters."""
    p = dict(zip(LINK_PARAMS, np.asarray(phi_link, dtype=float).reshape(N_LINK_PARAMS), strict=True))
    Io = np.array([[p["XX"], p["XY"], p["XZ"]], [p["XY"], p["YY"], p["YZ"]], [p["XZ"], p["YZ"], p["ZZ"]]])
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(Io) * np.eye(3) - Io
    J[:3, 3] = J[3, :3] = [p["MX"], p["MY"], p["MZ"]]
    J[3, 3] = p["M"]
    return J


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix uniform on SO(3): QR of a Gaussian matrix with the signs fixed (Mezzadri 2007)."""
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q = Q * np.sign(np.diag(R))[None, :]
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q


def random_inertia(n_links: int, length_scale: float, rng: np.random.Generator) -> RandomInertia:
    """Random physically consistent inertial parameters for ``n_links`` links.

    Per link: mass log-uniform in ``MASS_RANGE``; centre of mass uniform in the
    cube [−L/2, L/2]³ (L = ``length_scale``, the robot's size); principal
    spreads σ uniform in ``SPREAD_RANGE``·L, principal moments from them, and
    a uniformly random orientation of the principal axes.
    """
    if n_links < 1:
        raise ValueError(f"need at least one link, got {n_links}")
    L = float(length_scale)
    if not (np.isfinite(L) and L > 0):
        raise ValueError(f"length scale must be positive, got {length_scale}")
    mass = np.exp(rng.uniform(np.log(MASS_RANGE[0]), np.log(MASS_RANGE[1]), size=n_links))
    com = rng.uniform(-COM_BOX_FRACTION * L, COM_BOX_FRACTION * L, size=(n_links, 3))
    spread = rng.uniform(SPREAD_RANGE[0] * L, SPREAD_RANGE[1] * L, size=(n_links, 3))
    inertia_com = np.empty((n_links, 3, 3))
    phi = np.empty(N_LINK_PARAMS * n_links)
    for j in range(n_links):
        s2 = spread[j] ** 2
        principal = mass[j] * (s2.sum() - s2)  # J_x = m(σ_y² + σ_z²), ...
        R = random_rotation(rng)
        Ic = R @ np.diag(principal) @ R.T
        inertia_com[j] = 0.5 * (Ic + Ic.T)
        phi[N_LINK_PARAMS * j : N_LINK_PARAMS * (j + 1)] = standard_from_com(mass[j], com[j], inertia_com[j])
    return RandomInertia(mass=mass, com=com, inertia_com=inertia_com, phi=phi, length_scale=L)
