"""The paper's matrix (3): joint screws in Plücker coordinates, batched, and its normalised form.

Glazunov (1985), eq. (2)-(3): column i holds the unit screw of joint i,
(x_i, y_i, z_i; l_i, m_i, n_i) in the base frame, the moment taken about the
base origin: (e; r × e) for a revolute joint with unit axis e through r,
(0; e) for a prismatic joint.  The screws come from the same definition the
regressor uses (``dynamics.regressor.joint_screws``).

The normalised matrix takes the linear rows at the tool point O_c, divides
them by the chain's length scale L and multiplies prismatic columns by L, so
that its singular values are dimensionless and comparable across robots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import Chain, forward_kinematics
from minparam_cli.dynamics.regressor import joint_screws
from minparam_cli.errors import UnsupportedError

ZERO_COMPONENT = float(np.sqrt(np.finfo(float).eps))
"""Part of a unit-normalised screw below which the SVD cannot resolve it: treated as zero."""

TWIST_CONVENTION = (
    "(wx, wy, wz, vx, vy, vz): angular velocity in rad/s and velocity of the tool point O_c in m/s, "
    "components in the base frame"
)
SCREW_CONVENTION = (
    "Plücker (h; h0) in the base frame: h the axis vector, h0 the moment about the base origin; "
    "reciprocal to a twist (w; v_O) when h·v_O + h0·w = 0, v_O = v_c + r_c × w"
)


# --- the paper's matrix (3), batched ------------------------------------------


def require_serial(chain: Chain) -> None:
    """Refuse branched chains: the tool sits on the last link of a serial chain."""
    for j, p in enumerate(chain.parents):
        if p != j - 1:
            raise UnsupportedError(
                f"joint {chain.joint_names[j]!r} does not follow joint {j}; singular needs a serial chain",
                chain.source,
            )


def tool_points(chain: Chain, T: np.ndarray) -> np.ndarray:
    """O_c in the base frame, (N, 3): the chain's tool point in the last link frame, else its origin."""
    local = np.zeros(3) if chain.tool is None else np.asarray(chain.tool, dtype=float)
    last = T[:, -1]
    return last[:, :3, :3] @ local + last[:, :3, 3]


def plucker_matrices(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Matrix (3) for a batch of q: (N, 6, n) columns E_i (moments about the base origin), and O_c (N, 3)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    T, z, o = forward_kinematics(chain, q)
    S = joint_screws(chain, z, o)  # (N, n, 6)
    return np.swapaxes(S, 1, 2), tool_points(chain, T)


def rows_at_point(J0: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Move the linear rows from the base origin to the point c: v_c = v_O + ω × c.  (N, 6, n)."""
    J = np.array(J0, dtype=float, copy=True)
    w = J[..., :3, :]
    c = np.broadcast_to(c, J.shape[:-2] + (3,))
    J[..., 3:, :] += np.cross(w, c[..., :, None], axis=-2)
    return J


def column_scale(chain: Chain, L: float) -> np.ndarray:
    """Per-joint rate scale making the columns dimensionless: 1 for revolute, L for prismatic."""
    return np.where(chain.revolute, 1.0, L)


def normalised_matrices(chain: Chain, J0: np.ndarray, c: np.ndarray, L: float) -> np.ndarray:
    """Dimensionless screw matrix: linear rows at O_c divided by L, prismatic columns times L."""
    J = rows_at_point(J0, c)
    J[..., 3:, :] /= L
    return J * column_scale(chain, L)


def to_nd(T: np.ndarray, L: float) -> np.ndarray:
    """A twist (w; v at O_c) in the normalised matrix's units: (w; v / L)."""
    return np.concatenate([T[:3], T[3:] / L])


@dataclass(frozen=True, eq=False)
class ReciprocalScrew:
    """A unit screw reciprocal to every kept joint screw (|h| = 1, or |h0| = 1 for a couple)."""

    plucker: np.ndarray  # (h; h0) with h0 about the base origin
    moment_at_tool: np.ndarray  # h0 about O_c
    kind: str  # "screw" | "force" (zero pitch) | "couple" (h = 0)
    pitch: float  # inf for a couple, metres otherwise
    axis_point: np.ndarray | None  # point of the axis nearest the base origin (None for a couple)
