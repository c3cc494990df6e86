"""A known payload: its inertial parameters, and the drive gains, from a second recording.

Two recordings of the same robot, one without (A) and one with (B) a payload rigidly fixed to the
last link. The payload adds its 10 standard parameters φ_L (about the last link's frame origin,
``params.LINK_PARAMS``) to the last link's, so its torque is Y_n φ_L, Y_n the regressor's
columns of link n (Khalil & Dombre 2002, ch. 12).

With joint torques (or currents with known gains) the stacked system is

    A:  X θ              = τ_A
    B:  X θ + Y_n,u φ_u  = τ_B − Y_n,k φ_k

(u: the payload parameters to identify; k: those given, at least the mass M). With currents and
unknown drive gains g (τ = Nᵀ diag(g) c, one gain per motor; Gautier & Briot 2014, "Global
identification of joint drive gains and dynamic parameters of robots") the torques move to the
unknowns, C_k = Nᵀ e_k c_k:

    A:  X θ              − C g = 0
    B:  X θ + Y_n,u φ_u  − C g = −Y_n,k φ_k

and the known mass fixes the scale that currents alone leave free. Both are solved by weighted
least squares (per-joint weights 1/σ_j from a first ordinary fit, as in the main fit), with
cov = s² (AᵀWA)⁻¹, s² = ‖r_w‖² / (rows − unknowns). Payload parameters whose columns depend on the
columns before them (the robot's base set regroups them: XX and YY of a last revolute link only
through XX − YY) are not identifiable from torques and are reported as such.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from minparam_cli.dynamics.regressor import regressor
from minparam_cli.errors import ComputationError, InputError
from minparam_cli.identify.physical.report import Entry, GainsTLS, PayloadReport
from minparam_cli.params import LINK_PARAMS

# a payload column whose part outside the span of the columns before it is below this share of its norm
DEPENDENT_RTOL = 1e-6


@dataclass(frozen=True)
class PayloadSpec:
    """What is known of the payload: its mass (kg), optionally its centre of mass (m, last link
    frame) and its inertia about the centre of mass (ixx, ixy, ixz, iyy, iyz, izz, kg·m²)."""

    mass: float | None  # None: identified too (needs torques or known drive gains)
    com: tuple[float, float, float] | None = None
    inertia: tuple[float, ...] | None = None

    def known(self) -> dict[str, float]:
        """The standard parameters (about the last link's origin) that the spec fixes."""
        if self.mass is None:
            return {}
        out = {"M": self.mass}
        if self.com is not None:
            c = np.asarray(self.com, dtype=float)
            out.update(MX=self.mass * c[0], MY=self.mass * c[1], MZ=self.mass * c[2])
            if self.inertia is not None:
                ixx, ixy, ixz, iyy, iyz, izz = self.inertia
                Ic = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
                Io = Ic + self.mass * (c @ c * np.eye(3) - np.outer(c, c))
                out.update(XX=Io[0, 0], XY=Io[0, 1], XZ=Io[0, 2], YY=Io[1, 1], YZ=Io[1, 2], ZZ=Io[2, 2])
        return out


def check_spec(spec: PayloadSpec) -> None:
    if spec.mass is None:
        if spec.com is not None or spec.inertia is not None:
            raise InputError("--payload-com and --payload-inertia need --payload-mass")
        return
    if not (np.isfinite(spec.mass) and spec.mass > 0):
        raise InputError(f"--payload-mass must be a positive mass in kg, got {spec.mass:g}")
    for name, v in (("--payload-com", spec.com), ("--payload-inertia", spec.inertia)):
        if v is not None and not np.all(np.isfinite(v)):
            raise InputError(f"{name}: every value must be finite")
    if spec.inertia is not None and spec.com is None:
        raise InputError("--payload-inertia is about the centre of mass: give --payload-com too")


def payload_columns(chain, b) -> np.ndarray:
    """(N, dof, 10): the last link's standard columns, the torque of a unit payload parameter."""
    if chain.layout.numbers is not None or chain.coupling is not None:
        raise InputError("a payload needs a fixed-base serial chain without mimic joints")
    Y = regressor(chain, b.q, b.dq, b.ddq, include_extras=False)
    n = chain.n
    return Y[:, :, 10 * (n - 1) : 10 * n]


def gain_columns(chain, b, motor: np.ndarray | None = None) -> np.ndarray:
    """(N, dof, n motors): C_k = Nᵀ e_k c_k, the joint torques of a unit gain of motor k; the
    currents c = N⁻ᵀ τ recovered from torques read with unit gains (``identify --current``).
    ``motor``: the N the currents were read through (None: the chain's transmission; the identity
    for joint-side currents, tau_j = k_j i_j)."""
    from minparam_cli.dynamics.transmission import motor_matrix

    N = motor_matrix(chain) if motor is None else motor
    c = np.linalg.solve(N.T, b.tau.T).T
    return np.einsum("sk,kj->sjk", c, N)


def fit_payload(design, unloaded, loaded, spec: PayloadSpec, gains_unknown: bool,
                motor: np.ndarray | None = None) -> PayloadReport:
    """Payload parameters (and drive gains when ``gains_unknown``) with σ; see the module docstring.
    ``motor``: N of the currents (``gain_columns``; the identity for joint-side currents)."""
    check_spec(spec)
    if gains_unknown and spec.mass is None:
        raise InputError("currents without drive gains: --payload-mass is needed, the known mass fixes the torque scale")
    chain = design.chain
    known = spec.known()
    unknown = [k for k in LINK_PARAMS if k not in known]
    XA, XB = design.columns(unloaded), design.columns(loaded)
    p = XA.shape[2]
    YL = payload_columns(chain, loaded)
    idx = {k: i for i, k in enumerate(LINK_PARAMS)}
    phi_k = np.zeros(10)
    for k, v in known.items():
        phi_k[idx[k]] = v
    n = chain.dof
    blocks_A = [XA, np.zeros(XA.shape[:2] + (len(unknown),))]
    blocks_B = [XB, YL[:, :, [idx[k] for k in unknown]]]
    rhs_A, rhs_B = unloaded.tau.copy(), loaded.tau - YL @ phi_k
    if gains_unknown:
        blocks_A.append(-gain_columns(chain, unloaded, motor))
        blocks_B.append(-gain_columns(chain, loaded, motor))
        rhs_A, rhs_B = np.zeros_like(rhs_A), -(YL @ phi_k)
    A = np.concatenate([np.concatenate(blocks_A, axis=2), np.concatenate(blocks_B, axis=2)])  # (N, n, P)
    b = np.concatenate([rhs_A, rhs_B])
    names = list(design.names) + [f"{k}L" for k in unknown] + ([f"g{k + 1}" for k in range(n)] if gains_unknown else [])
    # which columns can be identified: scan in order, drop a column that depends on the kept ones
    keep = _independent(A.reshape(-1, A.shape[2]))
    dropped_payload = [names[i] for i in range(p, p + len(unknown)) if i not in keep]
    missing_gain = [names[i] for i in range(p + len(unknown), A.shape[2]) if i not in keep]
    if missing_gain:
        raise ComputationError(f"the drive gains {', '.join(missing_gain)} cannot be separated from the model on these data "
                               "(the payload does not move those joints enough)")
    x, std, r = _wls(A[:, :, keep], b)
    tau = np.concatenate([unloaded.tau, loaded.tau])
    method = "weighted least squares"
    tls = None
    if gains_unknown:  # Gautier & Briot's total least squares, reported beside (an independent computation)
        gi = [keep.index(i) for i in range(p + len(unknown), A.shape[2])]
        xt, st = _tls(A[:, :, keep], b, r)
        tls = GainsTLS(TLS_METHOD, {f"motor {k + 1}": Entry.of(xt[j], st[j]) for k, j in enumerate(gi)})
    if gains_unknown:  # the currents sit in the regressor: refine on the currents themselves (no errors-in-variables bias)
        from minparam_cli.dynamics.transmission import motor_matrix

        lin = [keep.index(i) for i in keep if i < p + len(unknown)]
        gi = [keep.index(i) for i in range(p + len(unknown), A.shape[2])]
        Ninv = np.linalg.inv(motor_matrix(chain) if motor is None else motor)
        F = A[:, :, keep][:, :, lin]
        f0 = np.concatenate([np.zeros_like(unloaded.tau), YL @ phi_k])
        c = tau @ Ninv  # the currents (torques read with unit gains, back on the motor side)
        refined = _refine_gains(F, f0, c, Ninv, x[lin], x[gi])
        if refined is not None:
            x = np.empty(len(keep))
            x[lin], x[gi], std = refined[0], refined[1], np.empty(len(keep))
            std[lin], std[gi] = refined[2], refined[3]
            r = (F @ x[lin] + f0) - (c * x[gi]) @ _motor_to_joint(Ninv)
            method = "Gauss–Newton on the motor currents (errors in the currents only), started from weighted least squares"
        g = x[gi]
        tau = np.concatenate([gain_columns(chain, unloaded, motor), gain_columns(chain, loaded, motor)]) @ g
    rel = float(np.linalg.norm(r) / np.linalg.norm(tau)) if np.linalg.norm(tau) > 0 else float("nan")
    sigma_j = np.sqrt(np.mean(r**2, axis=0))
    full = dict(zip([names[i] for i in keep], zip(x, std, strict=True), strict=True))

    params = {k: Entry.of(*full[f"{k}L"]) for k in unknown if f"{k}L" in full}
    mass = spec.mass if spec.mass is not None else (params["M"].value if "M" in params else None)
    com = None
    if spec.com is None and mass and all(k in params for k in ("MX", "MY", "MZ")):
        com = tuple(params[k].value / mass for k in ("MX", "MY", "MZ"))
    gains = base = None
    if gains_unknown:  # the gains and the model in the unit the known mass fixed (N·m)
        gains = {f"motor {k + 1}": Entry.of(*full[f"g{k + 1}"]) for k in range(n)}
        base = {name: Entry.of(*full[name]) for name in design.names if name in full}
    return PayloadReport(method=method, known={k: float(v) for k, v in known.items()},
                         frame=f"link {chain.n} ({chain.link_names[-1]})", parameters=params,
                         not_identifiable=tuple(k[:-1] for k in dropped_payload), samples=(len(unloaded), len(loaded)),
                         relative_error=rel, sigma_per_joint=tuple(sigma_j.tolist()), com=com, drive_gains=gains,
                         base_parameters=base, total_least_squares=tls)


TLS_METHOD = ("total least squares of the stacked unloaded and loaded recordings, [W, -C | -Y_k phi_k] "
              "(Gautier & Briot 2014), rows weighted per joint, columns equilibrated; σ first-order")


def _tls(A: np.ndarray, b: np.ndarray, r_wls: np.ndarray):
    """Total least squares of A x ≈ b (A (S, n, P), b (S, n)): Gautier & Briot's global identification
    of drive gains, where the currents sit in A (the columns −C g) and the known payload's torque is
    the right-hand side. Rows are weighted by 1/σ_j of joint j (from the least-squares residuals
    ``r_wls``), the columns of [A_w | b_w] scaled to unit norm (TLS assumes errors of one size in every
    column); x from the right singular vector v of the smallest singular value s, x = −v[:P] / v[P]
    (unscaled). σ from the first-order TLS covariance (Van Huffel & Vandewalle 1991, §8):
    cov(z) ≈ σ̂² (1 + ‖z‖²) (A'ᵀA' − s² I)⁻¹, σ̂² = s² / (rows − P), in the scaled unknowns z."""
    S, n, P = A.shape
    sigma_j = np.sqrt(np.mean(r_wls**2, axis=0))
    sigma_j = np.where(sigma_j > 0, sigma_j, 1.0)
    M = np.concatenate([(A / sigma_j[None, :, None]).reshape(-1, P), (b / sigma_j[None, :]).reshape(-1, 1)], axis=1)
    d = np.linalg.norm(M, axis=0)
    d = np.where(d > 0, d, 1.0)
    Ms = M / d
    _, sv, vt = np.linalg.svd(Ms, full_matrices=False)
    v = vt[-1]
    if abs(v[P]) < np.finfo(float).eps:
        raise ComputationError("total least squares: the payload's torque is not in the data's model (no unique solution)")
    z = -v[:P] / v[P]
    smin = sv[-1]
    s2 = smin**2 / max(Ms.shape[0] - P, 1)
    As = Ms[:, :P]
    cov_z = s2 * (1.0 + z @ z) * np.linalg.pinv(As.T @ As - smin**2 * np.eye(P))
    scale = d[P] / d[:P]  # A x = b  <=>  A' z = b' with z_i = x_i d_i / d_b
    x = z * scale
    std = np.sqrt(np.maximum(np.diag(cov_z), 0.0)) * scale
    return x, std


def _motor_to_joint(Ninv: np.ndarray) -> np.ndarray:
    """Rows of motor torques times this are joint torques (τ = Nᵀτ_m, i.e. τ_row = τ_m,row · N)."""
    return np.linalg.inv(Ninv)


REFINE_ITERATIONS = 50
REFINE_RTOL = 1e-10


def _refine_gains(F, f0, c, Ninv, x0, g0):
    """Drive gains and model by minimising Σ_k w_k ‖c_k − h_k m_k‖² over the motor currents c (the
    measured signal), m = N⁻ᵀ(F x + f0) the model's motor torques, h_k = 1/g_k: the noise sits in
    c, not in the regressor, so the estimate is not attenuated as least squares with C in the
    regressor is (errors in variables). Gauss–Newton from the least-squares values, w_k = 1/σ_k²
    of their current residuals; σ from the Jacobian at the optimum. None when it does not
    converge (the least-squares values stay)."""
    if np.any(g0 <= 0):
        return None
    G = np.einsum("sjp,jk->skp", F, Ninv)  # motor torque of each column: (S, n, P)
    m0 = f0 @ Ninv
    S, n, P = G.shape
    z = np.concatenate([x0, 1.0 / g0])
    w = None

    def residual(z):
        m = G @ z[:P] + m0
        return c - z[P:] * m, m

    res, m = residual(z)
    w = 1.0 / np.maximum(np.mean(res**2, axis=0), np.finfo(float).tiny)
    sw = np.sqrt(w)
    cost = float(np.sum(w * res**2))
    J = np.zeros((S * n, P + n))
    for _ in range(REFINE_ITERATIONS):
        J[:, :P] = -(G * (sw * z[P:])[None, :, None]).reshape(-1, P)
        J[:, P:] = 0.0
        for k in range(n):
            J[k::n, P + k] = -sw[k] * m[:, k]
        step = np.linalg.lstsq(J, -(sw * res).reshape(-1), rcond=None)[0]
        t = 1.0
        while t > 1e-6:
            z_new = z + t * step
            res_new, m_new = residual(z_new)
            cost_new = float(np.sum(w * res_new**2))
            if cost_new <= cost:
                break
            t /= 2
        else:
            break
        z, res, m, converged = z_new, res_new, m_new, cost - cost_new <= REFINE_RTOL * cost
        cost = cost_new
        if converged:
            break
    else:
        return None
    h = z[P:]
    if np.any(h <= 0):
        return None
    J[:, :P] = -(G * (sw * h)[None, :, None]).reshape(-1, P)
    for k in range(n):
        J[k::n, P + k] = -sw[k] * m[:, k]
    s2 = cost / max(S * n - P - n, 1)
    sd = np.sqrt(np.maximum(np.diag(s2 * np.linalg.pinv(J.T @ J)), 0.0))
    return z[:P], 1.0 / h, sd[:P], sd[P:] / h**2


def _independent(M: np.ndarray) -> list[int]:
    """Columns of M kept by the in-order scan: a column is dropped when the part of it outside the
    span of the kept columns before it is below DEPENDENT_RTOL of its norm (or it is zero)."""
    norms = np.linalg.norm(M, axis=0)
    Q = np.zeros((M.shape[0], 0))
    keep = []
    for i in range(M.shape[1]):
        if norms[i] == 0:
            continue
        v = M[:, i] / norms[i]
        for _ in range(2):
            v = v - Q @ (Q.T @ v)
        r = np.linalg.norm(v)
        if r > DEPENDENT_RTOL:
            keep.append(i)
            Q = np.column_stack([Q, v / r])
    return keep


def _wls(A: np.ndarray, b: np.ndarray):
    """Two-step per-joint weighted least squares; values, σ and the (unweighted) residuals."""
    N, n, P = A.shape
    x = np.linalg.lstsq(A.reshape(-1, P), b.reshape(-1), rcond=None)[0]
    r = b - A @ x
    sigma_j = np.sqrt(np.sum(r**2, axis=0) / max(N - P / n, 1.0))
    sigma_j = np.where(sigma_j > 0, sigma_j, 1.0)
    Aw, bw = (A / sigma_j[None, :, None]).reshape(-1, P), (b / sigma_j[None, :]).reshape(-1)
    x, *_ = np.linalg.lstsq(Aw, bw, rcond=None)
    rw = bw - Aw @ x
    s2 = float(rw @ rw) / max(len(bw) - P, 1)
    cov = s2 * np.linalg.pinv(Aw.T @ Aw)
    return x, np.sqrt(np.maximum(np.diag(cov), 0.0)), b - A @ x


def payload_report(design, data_path, payload_path, data_opts, spec: PayloadSpec, gains_unknown: bool,
                   motor: np.ndarray | None = None) -> PayloadReport:
    """Read the whole unloaded and loaded files (same preprocessing as the main fit) and fit the payload."""
    from minparam_cli.measured.blocks import load_all

    check_spec(spec)
    n = design.chain.dof
    unloaded, loaded = load_all(data_path, n, data_opts), load_all(payload_path, n, data_opts)
    return replace(fit_payload(design, unloaded, loaded, spec, gains_unknown, motor), files=(str(data_path), str(payload_path)))


def with_payload(sim, chain, spec: PayloadSpec):
    """A simulation with the payload's torque Y_n φ_L added (``simulate --payload-mass``)."""

    check_spec(spec)
    phi = np.zeros(10)
    for k, v in spec.known().items():
        phi[LINK_PARAMS.index(k)] = v
    extra = payload_columns(chain, sim) @ phi
    return replace(sim, tau=sim.tau + extra, tau_rigid=sim.tau_rigid + extra)
