"""The physically consistent fit (`identify --physical`): a convex program over the full parameters.

Least squares gives the base parameters β; they can imply bodies no link
can be (negative masses, inertia tensors that violate the triangle
inequality).  Here the unknowns are the full standard parameters φ
(``params.LINK_PARAMS`` per link, then the declared extras) and the
coefficients c of the effects the diagnosis added, with β = K·φ (K from the
derive stage, ``BaseSet.K``):

    minimise   (1/N) ‖R (θ(φ, c); −1)‖²  +  W·P(φ)   [+ TIE_BREAK·T(φ) without a prior]
    such that  J_i(φ) ⪰ ε_J·D,  D = diag(L², L², L², 1)  for every link i
               tr((J_i(φ) − ε_J·D)·Q_i) ≥ 0           links with an ellipsoid (--geometry; geometry.py)
               lo_i ≤ m_i ≤ hi_i,  Σ m_i = M           (--mass-bounds, --total-mass)
               Ia, Fc, Fv ≥ 0                          (declared extras)
               c within each effect's physical range   (``effects.EFFECTS[...].bounds``)

* R: the triangular factor of the weighted fit data [X | τ] (rows of joint j
  divided by σ_j, Gautier's weights of the unconstrained fit, or 1 with
  --ols), θ = [K·φ; c]; N the number of fit equations, so the data term is
  the mean squared weighted residual, ≈ 1 at the optimum.
* J_i(φ) = [[½tr(I_O)·1 − I_O, h], [hᵀ, m]], the pseudo-inertia of link i:
  J ⪰ 0 is exactly "a mass distribution exists" (Wensing, Kim & Slotine,
  IEEE RA-L 3(1), 2018); it implies m ≥ 0, I_C ⪰ 0 and the triangle
  inequalities of the principal moments about the centre of mass.  ε_J
  (``J_MARGIN``, kg, with L the robot's size) keeps every mass strictly
  positive so that a centre of mass exists.  Sousa & Cortesão (IJRR 33(6),
  2014) wrote the weaker m > 0, I_C ≻ 0 as LMIs.
* P(φ), the optional prior (``--prior nominal``): the mean of
  ((φ_k − φ_nom,k)/s_k)² over the inertial parameters, with s_k = |φ_nom,k|
  plus a tenth of the largest nominal value of the same kind (mass, first
  moment, second moment) in the same link, so every parameter is compared
  with its own link's size.
  W is ``--prior-weight`` (default 1e-2, docs/methods/physical.md: chosen on
  synthetic data): the prior outweighs the data only in directions the data
  barely see.  identify's ``--prior auto`` (the default) uses it whenever the
  description has inertials; provenance.py says per link what held what.
* Without a prior, the directions the data cannot see (the parameters that
  regroup, K's null space) are free, and the interior-point solver stops
  anywhere among the equally good bodies: links 1-3 of the Panda recording
  came out at 3347, 2954 and 301 kg.  The tie-break ``TIE_BREAK``·T(φ), with
  T(φ) = Σ_i (½tr(I_O,i)/L² + m_i) the total size of the bodies and weight
  1e-4, picks light bodies instead (0, 5.6 and 4.6 kg there; the data cannot
  say more).  Its price, measured on the same run: the data term rises by
  0.06 % and no base parameter moves by more than 0.28 of its σ.  (Minimising
  T among the bodies within 1e-6 of the optimal data cost, as a second
  program, failed in Clarabel on that run and left 18 kg at 1e-4.)

The program is solved by cvxpy with Clarabel (SCS if Clarabel is missing)
on R, whose size is that of the design, not of the data: the time does not
grow with the number of samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.errors import ComputationError, InputError
from minparam_cli.params import LINK_PARAMS, N_LINK_PARAMS

J_MARGIN = 1e-6  # kg: J_i ⪰ J_MARGIN·diag(L², L², L², 1)
TIE_BREAK = 1e-4  # weight of the lightest-body tie-break (no prior only)
DEFAULT_PRIOR_WEIGHT = 1e-2  # docs/methods/physical.md, "The prior's weight": measured on synthetic data
# a direction of a link's parameters is "informed" by the data when the data term's curvature along it
# exceeds the prior's by this factor
INFORMED_RATIO = 10.0
KINDS = {"XX": "inertia", "XY": "inertia", "XZ": "inertia", "YY": "inertia", "YZ": "inertia", "ZZ": "inertia",
         "MX": "moment", "MY": "moment", "MZ": "moment", "M": "mass"}
SIGNED_EXTRAS = {"Ia": 0.0, "Fc": 0.0, "Fv": 0.0, "Iam": 0.0, "Fcm": 0.0, "Fvm": 0.0}  # extras with a lower bound; OFF is free


@dataclass(frozen=True)
class PhysicalOptions:
    prior: str = "none"  # "none" | "nominal" (identify's --prior auto resolved against the description)
    prior_weight: float = DEFAULT_PRIOR_WEIGHT
    margin: float = J_MARGIN
    mass_bounds: tuple[tuple[float, float], ...] = ()  # per link (provenance.per_link_bounds); () none
    total_mass: float | None = None  # the links' masses sum to it (kg)
    ellipsoids: tuple = ()  # per link: geometry.Ellipsoid or None; () no geometry


@dataclass(frozen=True)
class PhysicalFit:
    phi: np.ndarray  # full standard parameters, chain.layout order
    theta: np.ndarray  # the design's parameters: [K·φ; effect coefficients]
    names: tuple[str, ...]  # names of phi
    solver: str
    status: str
    data_cost: float  # mean squared weighted residual on the fit data
    prior_cost: float
    informed: tuple[int, ...]  # per link: how many of its 10 parameter directions the data (not the prior) set
    elapsed_s: float


def length_scale(chain) -> float:
    """The robot's size L (m), as the chain gives it (its largest joint offset), at least 0.1 m."""
    return max(float(chain.length_scale), 0.1)


def pseudo_inertia(cp, phi_link):
    """J(φ) for one link's 10 parameters, as a cvxpy expression (Wensing et al. 2018)."""
    p = {k: phi_link[i] for i, k in enumerate(LINK_PARAMS)}
    tr = (p["XX"] + p["YY"] + p["ZZ"]) / 2
    return cp.bmat([
        [tr - p["XX"], -p["XY"], -p["XZ"], p["MX"]],
        [-p["XY"], tr - p["YY"], -p["YZ"], p["MY"]],
        [-p["XZ"], -p["YZ"], tr - p["ZZ"], p["MZ"]],
        [p["MX"], p["MY"], p["MZ"], p["M"]],
    ])


def _prior_scales(phi_nom: np.ndarray, n: int) -> np.ndarray:
    """s_k = |φ_nom,k| + a tenth of the largest nominal value of the same kind in the same link."""
    s = np.zeros(N_LINK_PARAMS * n)
    kind = np.array([KINDS[k] for k in LINK_PARAMS])
    for i in range(n):
        block = np.abs(phi_nom[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)])
        for k in set(kind):
            mask = kind == k
            s[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)][mask] = block[mask] + 0.1 * block[mask].max()
    positive = s[s > 0]
    return np.where(s > 0, s, positive.min() if positive.size else 1.0)


def fit_physical(chain, K: np.ndarray, design, R: np.ndarray, n_eq: int, opts: PhysicalOptions) -> PhysicalFit:
    """Solve the program above.  ``R``: (rows, p + 1) with ‖R (θ; −1)‖² the weighted fit-data cost of
    the design's parameters θ (p columns: the base parameters, then the effect columns)."""
    import time

    from minparam_cli.dynamics.effects import EFFECTS

    from minparam_cli.optional import import_optional

    cp = import_optional("cvxpy", "physical", "identify --physical")
    t0 = time.perf_counter()
    n_inertial = chain.layout.n_inertial
    n = n_inertial // N_LINK_PARAMS  # links (every link carries 10 parameters)
    P = chain.layout.size
    nb = len(design.kept)
    p = design.p
    if R.shape[1] != p + 1 or K.shape != (nb, P):
        raise ComputationError(f"physical fit: a design of {p} columns with K of shape {K.shape}")
    # one triangle for all joints: the program's size is the design's
    Rq: np.ndarray = np.linalg.qr(R, mode="r")  # type: ignore[assignment]  # numpy stubs: qr() gives QRResult for every mode; mode="r" returns R
    # column scaling keeps the conic solver's numbers near one; it changes nothing in the solution
    scale = np.linalg.norm(Rq[:, :p], axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    A = Rq[:, :p] / scale
    y = Rq[:, p]
    L = length_scale(chain)

    phi = cp.Variable(P)
    c = cp.Variable(p - nb) if p > nb else None
    theta = cp.hstack([K @ phi, c]) if c is not None else K @ phi
    resid = A @ cp.multiply(scale, theta) - y  # ‖R (θ; −1)‖ = ‖A θ − y‖
    data = cp.sum_squares(resid) / max(n_eq, 1)
    cons = []
    margin = np.diag([L * L, L * L, L * L, 1.0]) * opts.margin
    for i in range(n):
        J = pseudo_inertia(cp, phi[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)])
        cons.append(J - margin >> 0)
        ell = opts.ellipsoids[i] if i < len(opts.ellipsoids) else None
        if ell is not None:  # the body beyond the margin inside the link's ellipsoid: tr((J − εD)·Q) ≥ 0 (geometry.py)
            cons.append(cp.sum(cp.multiply(J - margin, ell.q())) >= 0)
    cons += _mass_constraints(phi, n, opts)
    names = chain.layout.names
    for k in range(n_inertial, P):
        kind = names[k].rstrip("0123456789")
        if kind in SIGNED_EXTRAS:
            cons.append(phi[k] >= SIGNED_EXTRAS[kind])
    col = 0
    for t in design.terms:
        b = EFFECTS[t.effect].bounds
        w = t.width()
        if b is not None:
            assert c is not None  # a design with terms has columns past the base parameters
            if np.isfinite(b[0]):
                cons.append(c[col : col + w] >= b[0])
            if np.isfinite(b[1]):
                cons.append(c[col : col + w] <= b[1])
        col += w
    size = sum((phi[N_LINK_PARAMS * i + 0] + phi[N_LINK_PARAMS * i + 3] + phi[N_LINK_PARAMS * i + 5]) / (2 * L * L)
               + phi[N_LINK_PARAMS * i + 9] for i in range(n))
    prior = None
    objective = data
    if opts.prior == "nominal":
        if chain.phi_nominal is None:
            raise InputError("--prior nominal: the robot description has no inertial values to use as the prior")
        from minparam_cli.dynamics.bodies import nominal_problems, nominal_problems_text

        problems = nominal_problems(chain)
        if problems:  # a prior outside the feasible set pulls the fit toward no body at all
            raise InputError("--prior nominal: " + nominal_problems_text(chain.source, problems))
        nom = np.asarray(chain.phi_nominal, dtype=float)[:n_inertial]
        s = _prior_scales(nom, n)
        prior = cp.sum_squares(cp.multiply(1.0 / s, phi[:n_inertial] - nom)) / n_inertial
        objective = objective + opts.prior_weight * prior
    if prior is None:
        objective = objective + TIE_BREAK * size
    solvers = [x for x in ("CLARABEL", "SCS") if x in cp.installed_solvers()]
    problem = cp.Problem(cp.Minimize(objective), cons)
    solver = _solve(cp, problem, solvers, lambda: _violation(np.asarray(phi.value, dtype=float), n, L, opts))
    status = problem.status
    phi_v = np.asarray(phi.value, dtype=float)
    theta_v = np.concatenate([K @ phi_v, np.asarray(c.value, dtype=float)]) if c is not None else K @ phi_v
    informed = _informed(A, scale, K, n, n_eq, opts, chain)
    data_cost = float(np.sum((A @ (scale * theta_v) - y) ** 2)) / max(n_eq, 1)
    prior_cost = float(prior.value) if prior is not None else 0.0
    return PhysicalFit(phi_v, theta_v, tuple(names), solver.lower(), status, data_cost,
                       prior_cost, informed, time.perf_counter() - t0)


def _mass_constraints(phi, n: int, opts: PhysicalOptions) -> list:
    """lo_i ≤ m_i ≤ hi_i (--mass-bounds) and Σ m_i = M (--total-mass)."""
    out = []
    for i, (lo, hi) in enumerate(opts.mass_bounds[:n]):
        if lo > 0:
            out.append(phi[N_LINK_PARAMS * i + 9] >= lo)
        if np.isfinite(hi):
            out.append(phi[N_LINK_PARAMS * i + 9] <= hi)
    if opts.total_mass is not None:
        out.append(sum(phi[N_LINK_PARAMS * i + 9] for i in range(n)) == opts.total_mass)
    return out


def _solve(cp, problem, solvers: list[str], violation) -> str:
    """Solve with the first solver that ends optimal with a solution that keeps the constraints
    (``violation()``: None, or what it breaks); the one that did."""
    whys = []
    for solver in solvers:
        try:
            problem.solve(solver=solver)
        except cp.error.SolverError as e:
            whys.append(f"{solver} failed ({str(e).split('.')[0]})")
            continue
        if problem.status in ("optimal", "optimal_inaccurate"):
            broken = violation()
            if broken is None:
                return solver
            whys.append(f"{solver} ended '{problem.status}' with {broken}")
            continue
        whys.append(f"{solver} ended '{problem.status}'")
    why = "; ".join(whys) or "no conic solver installed (Clarabel or SCS)"
    raise ComputationError(f"physical fit: {why}")


def _violation(phi: np.ndarray, n: int, L: float, opts: PhysicalOptions) -> str | None:
    """What a solver's φ breaks by more than a millionth of a kilogram-sized body (absolute: the
    solvers' feasibility tolerance is absolute, and a link the data leave free sits at the margin ε):
    a link's pseudo-inertia (J ⪰ 0), its ellipsoid or its mass bounds; None when nothing.  An
    inaccurate solution can return bodies that are none (SCS did: a mass with λ_min(J) = −1.3)."""
    from minparam_cli.dynamics.inertia import pseudo_inertia_from_standard

    d = np.array([1 / L, 1 / L, 1 / L, 1.0])
    margin = np.diag([L * L, L * L, L * L, 1.0]) * opts.margin
    for i in range(n):
        J = pseudo_inertia_from_standard(phi[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)])
        tol = 1e-6 * max(float(np.abs(J * np.outer(d, d)).max()), 1.0)
        if np.linalg.eigvalsh(J * np.outer(d, d))[0] < -tol:
            return f"link {i + 1} not a body"
        ell = opts.ellipsoids[i] if i < len(opts.ellipsoids) else None
        if ell is not None:
            Q = ell.q()
            if float(np.sum((J - margin) * Q)) < -tol * float(np.abs(Q / np.outer(d, d)).max()):
                return f"link {i + 1} outside its ellipsoid"
        m = phi[N_LINK_PARAMS * i + 9]
        lo, hi = opts.mass_bounds[i] if i < len(opts.mass_bounds) else (0.0, np.inf)
        if m < lo - tol or m > hi + tol:
            return f"link {i + 1}'s mass outside its bounds"
    return None


def _informed(A: np.ndarray, scale: np.ndarray, K: np.ndarray, n: int, n_eq: int, opts: PhysicalOptions, chain) -> tuple[int, ...]:
    """Per link, how many of its 10 parameter directions the data set: eigen-directions of the data term's
    curvature on that link's parameters (in the prior's units φ_k / s_k) that exceed INFORMED_RATIO times
    the prior's curvature; without a prior, those above 1e-10 of the largest (the others are directions
    the data cannot see at all: masses of links that only regroup, for instance)."""
    nb = K.shape[0]
    Ab = A[:, :nb] * scale[:nb]  # the data matrix on the base parameters, unscaled
    if opts.prior == "nominal" and chain.phi_nominal is not None:
        s = _prior_scales(np.asarray(chain.phi_nominal, dtype=float)[: N_LINK_PARAMS * n], n)
        floor = INFORMED_RATIO * opts.prior_weight / (N_LINK_PARAMS * n)
    else:
        s, floor = np.ones(N_LINK_PARAMS * n), None
    curv = []
    for i in range(n):
        sl = slice(N_LINK_PARAMS * i, N_LINK_PARAMS * (i + 1))
        C = (Ab @ K[:, sl]) * s[sl]
        curv.append(np.linalg.eigvalsh(C.T @ C / max(n_eq, 1)))
    top = max(float(c.max()) for c in curv) if curv else 0.0
    limit = floor if floor is not None else 1e-10 * top
    return tuple(int(np.sum(c > limit)) for c in curv)


def link_bodies(phi: np.ndarray, n: int) -> list[dict]:
    """Mass, centre of mass, inertia about it (link-frame axes), principal moments, and the smallest
    eigenvalue of the pseudo-inertia, per link."""
    from minparam_cli.dynamics.inertia import body_from_standard, pseudo_inertia_from_standard

    out = []
    for i in range(n):
        phi_link = phi[N_LINK_PARAMS * i : N_LINK_PARAMS * (i + 1)]
        m, c, Ic = body_from_standard(phi_link)
        principal = np.linalg.eigvalsh(0.5 * (Ic + Ic.T))
        J = pseudo_inertia_from_standard(phi_link)
        out.append({"link": i + 1, "mass": m, "com": [float(x) for x in c], "inertia_com": Ic.tolist(),
                    "principal_moments": [float(x) for x in principal],
                    "triangle_margin": float(min(principal[0] + principal[1] - principal[2],
                                                 principal[0] + principal[2] - principal[1],
                                                 principal[1] + principal[2] - principal[0])),
                    "pseudo_inertia_min_eig": float(np.linalg.eigvalsh(J)[0])})
    return out
