"""Where each link's values in the physical fit come from, whether they are fixed, and the export's refusal.

Of a link's ten parameter directions the data set ``informed`` (convex._informed); the other
10 − informed are held, in this order, by

1. the prior (the description's nominal inertials), when the fit has one: the link is fixed;
2. its geometry and a bound on its mass: the ellipsoid (geometry.py) together with a finite upper
   bound on the mass (``--mass-bounds``, or ``--total-mass``: masses are ≥ 0 and sum to it) confine
   the ten parameters to a bounded set (mass in [lo, hi], first moments within mass × the ellipsoid's
   reach, second moments within mass × its extent²).  The link counts as fixed: a value picked
   inside that set by the tie-break is a body the link can be, though not a measured one;
3. nothing but the lightest-body tie-break: the link is **not fixed**.  Its exported body would be
   the solver's choice among equally good ones (link 1 of the Panda recording came out at 2.3 mg):
   ``--export-urdf``/``--export-yaml`` refuse it (``refusal``).

A mass bound without geometry leaves the first and second moments free, and geometry without a mass
bound leaves the scale free (a lighter body of the same shape is as inside): neither alone fixes a
link.  A body on the boundary of physical consistency (the smallest eigenvalue of its pseudo-inertia,
scaled by the robot's size, within ``BOUNDARY_FACTOR`` of the margin ε) is reported and flagged:
its mass lies on a plane, a line or a point, which no real link's does.
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import InputError

BOUNDARY_FACTOR = 10.0  # a body is "on the boundary" when λ_min(D⁻½ J D⁻½) ≤ BOUNDARY_FACTOR·ε


def per_link_bounds(bounds: tuple[tuple[float, float], ...], n: int) -> tuple[tuple[float, float], ...]:
    """--mass-bounds for each of the n links: one pair for all, or one per link (else one-line error)."""
    if not bounds:
        return ((0.0, math.inf),) * n
    if len(bounds) == 1:
        return tuple(bounds) * n
    if len(bounds) != n:
        raise InputError(f"--mass-bounds: {len(bounds)} pairs LO:HI for {n} links; give one LO,HI for every link "
                         f"or {n} pairs LO:HI")
    return tuple(bounds)


def check_total_mass(bounds: tuple[tuple[float, float], ...], total: float | None) -> None:
    if total is None:
        return
    lo, hi = sum(b[0] for b in bounds), sum(b[1] for b in bounds)
    if not (lo <= total <= hi):
        raise InputError(f"--total-mass {total:g}: the --mass-bounds allow a total between {lo:g} and {hi:g} kg")


def sources(informed: int, prior: bool, ellipsoid: bool, mass_bounded: bool) -> tuple[dict[str, int], bool]:
    """(directions per source, fixed) of one link, by the order of the module docstring."""
    free = 10 - informed
    out = {"data": informed}
    if free == 0:
        return out, True
    if prior:
        out["prior"] = free
        return out, True
    if ellipsoid and mass_bounded:
        out["geometry/bounds"] = free
        return out, True
    out["tie-break"] = free
    return out, False


def on_boundary(phi_link, L: float, margin: float) -> bool:
    """Whether the body's scaled pseudo-inertia D⁻½ J D⁻½ (D = diag(L², L², L², 1)) has its smallest
    eigenvalue within BOUNDARY_FACTOR of the fit's margin ε."""
    from minparam_cli.dynamics.inertia import pseudo_inertia_from_standard

    J = pseudo_inertia_from_standard(np.asarray(phi_link, dtype=float))
    d = np.array([1 / L, 1 / L, 1 / L, 1.0])
    return bool(np.linalg.eigvalsh(J * np.outer(d, d))[0] <= BOUNDARY_FACTOR * margin)


def boundary_flag(links: list[int], margin: float) -> str:
    """The report's one-line warning for bodies on the boundary of physical consistency."""
    which = ", ".join(str(k) for k in links)
    return (f"physical fit: link{'s' if len(links) > 1 else ''} {which} sit on the boundary of physical consistency "
            f"(smallest pseudo-inertia eigenvalue at the margin {margin:g} kg): a mass on a plane, a line or a point, "
            "as no real link has; the data ask for bodies beyond the consistent ones (model error), or nothing holds them")


def refusal(link: str, informed: int, others: int, prior: str, has_inertials: bool, ellipsoid: str | None) -> str:
    """The one line with which an export refuses a link that nothing fixes (module docstring);
    ``ellipsoid``: where the link's ellipsoid comes from (None: it has none)."""
    more = f" (and {others} more link{'s' if others > 1 else ''})" if others else ""
    head = f"link '{link}'{more}: the data fix {informed} of its 10 parameter directions"
    if has_inertials and prior == "none":
        why = "and --prior none switched the description's inertials off: drop --prior none"
    elif ellipsoid is not None:
        why = ("and the description has no inertials: give inertials in the robot file (--prior nominal) or a mass "
               f"bound (--mass-bounds LO,HI or --total-mass KG), which with the link's ellipsoid ({ellipsoid}) fixes it")
    else:
        why = ("and the description has no inertials and no shapes for it: give inertials in the robot file "
               "(--prior nominal), or --mass-bounds with collision geometry in the URDF or geoms in the MJCF")
    return f"{head} {why}; nothing written"
