"""Where a link's mass can be: one bounding ellipsoid per link, as a linear constraint on its pseudo-inertia.

A mass distribution ρ inside the ellipsoid E = {x : (x − c)ᵀ Σ⁻¹ (x − c) ≤ 1} (link frame) satisfies

    tr(J·Q) = ∫ ρ(x) (1 − (x − c)ᵀ Σ⁻¹ (x − c)) dV ≥ 0,    Q = [[−Σ⁻¹, Σ⁻¹c], [cᵀΣ⁻¹, 1 − cᵀΣ⁻¹c]],

with J = ∫ ρ [x; 1][x; 1]ᵀ dV the pseudo-inertia: a constraint linear in the ten parameters
(Wensing, Kim & Slotine, IEEE RA-L 3(1), 2018, Sec. IV).  The fit keeps J ⪰ ε·D (convex.py; D =
diag(L², L², L², 1)) and asks it of the body beyond that margin: tr((J − ε·D)·Q) ≥ 0.  It bounds the shape of the distribution
relative to its mass, not the mass: a lighter body of the same shape satisfies it as well, so the
ellipsoid fixes a link's free directions only together with a bound on its mass (provenance.py).

Where the ellipsoid comes from:

* a URDF link with collision (else visual) shapes: the ellipsoid the loader stored on the chain
  (``Chain.link_geometry``: √3 times the half-widths of the box that holds every shape; see
  describe/urdf_geometry.py);
* a DH/MDH table, which has no shapes (``dh_ellipsoid``, a heuristic): the points a link must reach,
  in its frame — where its joint sits, the feet on its joint axis of its parent's frame origin and of
  its own (a DH or MDH offset d lies along that axis), its frame's origin, and where each child's
  joint sits — held in their bounding box widened by r = L/4 on every side (L the robot's size), and
  the ellipsoid through that box's corners (semi-axes √3 times its half-widths).  For a link of a
  planar arm with length a that is the spheroid of semi-axes √3(a/2 + r), √3r, √3r around the
  link's segment; for the Panda's link 3 (MDH) it reaches from the shoulder, 0.316 m down its axis,
  to the elbow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.params import N_LINK_PARAMS

RADIUS_FLOOR = 0.25  # the DH heuristic widens the box of a link's points by RADIUS_FLOOR·L


@dataclass(frozen=True)
class Ellipsoid:
    """{x : (x − c)ᵀ Σ⁻¹ (x − c) ≤ 1} in the link frame (m), and where it comes from."""

    centre: tuple[float, ...]  # c (m), three values
    sigma: tuple[tuple[float, ...], ...]  # Σ (m²), 3×3 symmetric positive definite
    source: str  # "collision", "visual", "DH segment"

    def q(self) -> np.ndarray:
        """Q of the module docstring: tr(J·Q) ≥ 0 ⇔ the mass is inside (for a distribution)."""
        c = np.asarray(self.centre, dtype=float)
        Si = np.linalg.inv(np.asarray(self.sigma, dtype=float))
        Q = np.zeros((4, 4))
        Q[:3, :3] = -Si
        Q[:3, 3] = Q[3, :3] = Si @ c
        Q[3, 3] = 1.0 - c @ Si @ c
        return Q

    def semi_axes(self) -> tuple[float, ...]:
        return tuple(float(np.sqrt(max(v, 0.0))) for v in np.linalg.eigvalsh(np.asarray(self.sigma, dtype=float)))

    def to_dict(self) -> dict:
        return {"source": self.source, "centre": list(self.centre), "semi_axes": list(self.semi_axes())}


def box_ellipsoid(lo, hi, source: str) -> Ellipsoid:
    """The axis-aligned ellipsoid through the corners of the box [lo, hi]: semi-axes √3 times its
    half-widths (each at least a thousandth of the largest, so that Σ is invertible)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    half = (hi - lo) / 2
    half = np.maximum(half, 1e-3 * max(float(half.max()), 1e-6))
    c = (hi + lo) / 2
    return Ellipsoid(tuple(float(x) for x in c), tuple(tuple(float(x) for x in row) for row in np.diag(3 * half**2)), source)


def dh_points(chain, i: int) -> np.ndarray:
    """The points link i must reach, in its frame (module docstring), one per row."""
    pre, post = np.asarray(chain.pre[i], dtype=float), np.asarray(chain.post[i], dtype=float)
    a = np.asarray(chain.axes[i], dtype=float)
    post_inv = np.linalg.inv(post)
    parent = -pre[:3, :3].T @ pre[:3, 3]  # the parent frame's origin, in the joint frame F_parent·Pre
    own = post[:3, 3]  # the link frame's origin, in the joint frame (at q = 0)
    in_joint = [np.zeros(3), (parent @ a) * a, (own @ a) * a]  # on the axis: the same at every q
    pts = [post_inv[:3, :3] @ x + post_inv[:3, 3] for x in in_joint] + [np.zeros(3)]
    pts += [np.asarray(chain.pre[k][:3, 3], dtype=float) for k in chain.children(i)]
    return np.array(pts)


def dh_ellipsoid(chain, i: int, L: float) -> Ellipsoid:
    """Link i's heuristic ellipsoid from the joint offsets (module docstring)."""
    pts = dh_points(chain, i)
    r = RADIUS_FLOOR * L
    return box_ellipsoid(pts.min(axis=0) - r, pts.max(axis=0) + r, "DH segment")


def link_ellipsoids(chain, L: float) -> tuple[Ellipsoid | None, ...]:
    """Per link, the ellipsoid its mass is inside: the URDF's shapes, the DH heuristic for a DH/MDH
    table, None for a URDF link without shapes."""
    stored = getattr(chain, "link_geometry", ()) or ()
    out: list[Ellipsoid | None] = []
    for i in range(chain.n):
        if chain.convention in ("dh", "mdh"):
            out.append(dh_ellipsoid(chain, i, L))
        else:
            g = stored[i] if i < len(stored) else None
            out.append(None if g is None else box_ellipsoid(g[1], g[2], g[0]))
    return tuple(out)


def ellipsoid_slack(phi_link, ell: Ellipsoid, margin: float, L: float) -> float:
    """tr((J − ε·diag(L², L², L², 1))·Q) (kg) of one link's ten parameters, the constraint the fit keeps
    (the body beyond the margin ε inside the ellipsoid): ≥ 0 when it holds, 0 on its boundary."""
    from minparam_cli.dynamics.inertia import pseudo_inertia_from_standard

    J = pseudo_inertia_from_standard(np.asarray(phi_link, dtype=float)[:N_LINK_PARAMS])
    return float(np.sum((J - margin * np.diag([L * L, L * L, L * L, 1.0])) * ell.q()))
