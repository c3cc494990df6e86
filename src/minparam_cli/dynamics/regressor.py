"""Inverse-dynamics regressor Y(q, qd, qdd) by recursive Newton–Euler, vectorised over samples.

tau = Y(q, qd, qdd) · phi, with phi the standard parameters named in
``params.py`` (Khalil & Dombre, *Modeling, Identification and Control of
Robots*, 2002, ch. 9; Atkeson, An & Hollerbach 1986 for the linearity).

Forward pass (Featherstone's spatial vectors, expressed in the base frame at
its origin): every joint k has the screw S_k = (z_k, o_k × z_k) (revolute) or
(0, z_k) (prismatic), and

    V_j = V_p + S_j qd_j,          A_j = A_p + S_j qdd_j + V_j ×_m S_j qd_j,

with A_0 = (0, -g) so that gravity enters as an upward base acceleration.
Per link, the Newton–Euler wrench about the link frame origin, in link
coordinates, is linear in that link's 10 parameters:

    F = M·a + ω̇ × s + ω × (ω × s),     N = I·ω̇ + ω × (I·ω) + s × a,

(a the classical acceleration of the frame origin, s = (MX, MY, MZ)).
Backward pass: joint k carries the wrenches of every link in its subtree,
tau_k = S_kᵀ · W_j.  Extras add Ia·qdd_k, Fc·sign(qd_k) (or the smooth
Fc·tanh(qd_k / v_c), ``Chain.coulomb_smoothing``), Fv·qd_k and a constant,
each in its own column.

Motor-side columns of a declared transmission (Iamk, Fcmk, Fvmk: ``dynamics/transmission.py``)
are Nᵀe_k times a function of the motor's speed or acceleration (N q̇)_k, (N q̈)_k.

Mimic joints (``Chain.coupling``, q_joint = G·q + offset): the regressor of
every joint is computed at the joint states the coordinates give, then its
rows are combined by virtual work, Y = Gᵀ·Y_joints (the generalized force on
a master is τ_master + m·τ_mimic).

Two implementations of the inertial columns give the same numbers: numpy, all
links and samples at once (the reference, always available), and a compiled
kernel (``_rnea.c``, one sample at a time, built by setup.py when a C compiler
is present).  At 100 samples numpy spends its time in per-call overhead, the
kernel in arithmetic (benchmarks/bench_derive.py).
"""

from __future__ import annotations

import random
from types import ModuleType

import numpy as np

from minparam_cli.chain import REVOLUTE, Chain, derived, forward_kinematics
from minparam_cli.params import FRICTION_KINDS

JOINT_EXTRAS = ("rotor_inertia",) + FRICTION_KINDS  # extras of a joint's own signals (motor-side: transmission.py)

_rnea: ModuleType | None
try:  # compiled kernel (setup.py, optional): same numbers as the numpy reference below
    from minparam_cli.dynamics import _rnea
except ImportError:  # pragma: no cover - depends on the install having a C compiler
    _rnea = None


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays, broadcasting (np.cross is slow on small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


def link_wrench_regressor(omega, domega, acc) -> np.ndarray:
    """Wrench (N; F) about the link origin in link coordinates, as a (N, 6, 10) linear map of phi_j.

    Written out entry by entry: N = L(ω̇)·I + ω×(L(ω)·I) − [a]×·s and
    F = ([ω̇]× + ωωᵀ − |ω|²E)·s + a·M (batched 3x3 products are slow in numpy).
    """
    N = omega.shape[0]
    K = np.zeros((N, 6, 10))
    w1, w2, w3 = omega[:, 0], omega[:, 1], omega[:, 2]
    d1, d2, d3 = domega[:, 0], domega[:, 1], domega[:, 2]
    a1, a2, a3 = acc[:, 0], acc[:, 1], acc[:, 2]
    w11, w22, w33, w12, w13, w23 = w1 * w1, w2 * w2, w3 * w3, w1 * w2, w1 * w3, w2 * w3
    # moment, inertia columns XX XY XZ YY YZ ZZ: L(ω̇) + ω × (L(ω) ·)
    K[:, 0, 0], K[:, 0, 1], K[:, 0, 2], K[:, 0, 3], K[:, 0, 4], K[:, 0, 5] = d1, d2 - w13, d3 + w12, -w23, w22 - w33, w23
    K[:, 1, 0], K[:, 1, 1], K[:, 1, 2], K[:, 1, 3], K[:, 1, 4], K[:, 1, 5] = w13, d1 + w23, w33 - w11, d2, d3 - w12, -w13
    K[:, 2, 0], K[:, 2, 1], K[:, 2, 2], K[:, 2, 3], K[:, 2, 4], K[:, 2, 5] = -w12, w11 - w22, d1 - w23, w12, d2 + w13, d3
    # moment, first-moment columns: s × a = −[a]× s
    K[:, 0, 7], K[:, 0, 8] = a3, -a2
    K[:, 1, 6], K[:, 1, 8] = -a3, a1
    K[:, 2, 6], K[:, 2, 7] = a2, -a1
    # force, first-moment columns: [ω̇]× + ωωᵀ − |ω|² E
    K[:, 3, 6], K[:, 3, 7], K[:, 3, 8] = -w22 - w33, w12 - d3, w13 + d2
    K[:, 4, 6], K[:, 4, 7], K[:, 4, 8] = w12 + d3, -w11 - w33, w23 - d1
    K[:, 5, 6], K[:, 5, 7], K[:, 5, 8] = w13 - d2, w23 + d1, -w11 - w22
    K[:, 3:6, 9] = acc
    return K


def joint_screws(chain: Chain, z: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Unit joint screws (angular; linear at the base origin), (N, n, 6)."""
    S = np.zeros(z.shape[:-1] + (6,))
    for k, kind in enumerate(chain.types):
        if kind == REVOLUTE:
            S[:, k, :3] = z[:, k]
            S[:, k, 3:] = cross(o[:, k], z[:, k])
        else:
            S[:, k, 3:] = z[:, k]
    return S


def _kernel_arrays(chain: Chain):
    """The chain's constants laid out for the compiled kernel, built once per chain (kept beside it)."""
    return derived(chain, "kernel_arrays", _build_kernel_arrays)


def _build_kernel_arrays(chain: Chain):
    n = chain.n
    terms = np.zeros((n, 3, 4, 4))
    axor = np.zeros((n, 6))
    for j, ((C0, C1, C2), axis, origin) in enumerate(chain.local_terms):
        terms[j, 0], terms[j, 1] = C0, C1
        if C2 is not None:
            terms[j, 2] = C2
        axor[j, :3], axor[j, 3:] = axis, origin
    parents = np.array(chain.parents, dtype=np.int64)
    return terms, axor, parents, chain.revolute.astype(np.uint8), np.ascontiguousarray(chain.gravity, dtype=float)


def _carry_matrix(chain: Chain) -> np.ndarray:
    """carry[j, k] = 1 when joint k carries link j (k an ancestor of j, or j itself)."""
    carry = np.zeros((chain.n, chain.n))
    for j in range(chain.n):
        carry[j, list(chain.ancestors(j))] = 1.0
    return carry


def inertial_regressor_numpy(chain: Chain, q, qd, qdd, out: np.ndarray) -> None:
    """Reference implementation: fill out[:, :, :10 n] (out zeroed, shape (N, n, P)), every link at once.

    Spatial vectors at the base origin: V = carry·(S qd), A = a0 + carry·(S qdd + (V ×_m S) qd);
    each link's wrench regressor K_j (link coordinates) is moved to the base origin, W_j = X_j* K_j,
    and joint k reads Y[k, j] = S_kᵀ W_j when it carries link j.
    """
    N, n = q.shape
    T, z, o = forward_kinematics(chain, q)
    rev = chain.revolute
    carry = _carry_matrix(chain)
    S = np.empty((N, n, 6))
    S[..., :3] = z * rev[:, None]
    S[..., 3:] = cross(o, S[..., :3]) + z * (~rev)[:, None]
    Sd = S * qd[..., None]
    V = np.matmul(carry, Sd)
    w, v = V[..., :3], V[..., 3:]
    inc = S * qdd[..., None]
    inc[..., :3] += cross(w, Sd[..., :3])
    inc[..., 3:] += cross(w, Sd[..., 3:]) + cross(v, Sd[..., :3])
    A = np.matmul(carry, inc)
    A[..., 3:] -= chain.gravity
    R = T[..., :3, :3]
    pos = T[..., :3, 3]
    vo = v + cross(w, pos)
    ao = A[..., 3:] + cross(A[..., :3], pos) + cross(w, vo)
    local = np.matmul(np.swapaxes(R, -1, -2), np.stack([w, A[..., :3], ao], axis=-1))
    K = link_wrench_regressor(local[..., 0].reshape(-1, 3), local[..., 1].reshape(-1, 3), local[..., 2].reshape(-1, 3))
    K = K.reshape(N, n, 6, 10)
    W = np.empty((N, n, 6, 10))
    W[..., 3:, :] = np.matmul(R, K[..., 3:, :])
    W[..., :3, :] = np.matmul(R, K[..., :3, :]) + cross(pos[..., None, :], np.swapaxes(W[..., 3:, :], -1, -2)).swapaxes(-1, -2)
    Yb = np.matmul(S, W.transpose(0, 2, 1, 3).reshape(N, 6, n * 10)).reshape(N, n, n, 10)
    Yb *= carry.T[None, :, :, None]
    out[:, :, : 10 * n] = Yb.reshape(N, n, 10 * n)


def regressor(chain: Chain, q, qd, qdd, include_extras: bool = True, backend: str = "auto") -> np.ndarray:
    """Y with shape (N, dof, P): tau[s, k] = Y[s, k, :] @ phi, one row per independent coordinate.

    q, qd, qdd: (N, chain.dof), the independent coordinates (every joint when
    the chain has no mimic joints).  P = 10 n inertial columns, plus the extra
    columns of ``chain.layout`` when ``include_extras``.  ``backend``: "auto"
    (the compiled kernel when it was built, else numpy), "numpy" or "kernel";
    both give the same numbers (tests/test_kernel.py).
    """
    q, qd, qdd = (np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=float))) for x in (q, qd, qdd))
    if q.shape[1] != chain.dof or qd.shape != q.shape or qdd.shape != q.shape:
        raise ValueError(f"expected q, qd, qdd with shape (N, {chain.dof})")
    if chain.coupling is None:
        Y = joint_regressor(chain, q, qd, qdd, include_extras, backend)
        if include_extras and chain.transmission is not None:
            from minparam_cli.dynamics.transmission import add_motor_columns

            add_motor_columns(chain, Y, qd, qdd)
        return Y
    return chain.coupling.coordinate_rows(q, qd, qdd, lambda a, b, c: joint_regressor(chain, a, b, c, include_extras, backend))


def joint_regressor(chain: Chain, q, qd, qdd, include_extras: bool = True, backend: str = "auto") -> np.ndarray:
    """Y with shape (N, n, P), one row per joint of the chain, mimic joints included (their own
    torques, before the coupling): q, qd, qdd (N, n) C-contiguous float arrays of every joint."""
    N, n = q.shape
    if n != chain.n:
        raise ValueError(f"expected joint states with shape (N, {chain.n})")
    layout = chain.layout
    P = layout.size if include_extras else layout.n_inertial
    Y = np.zeros((N, n, P))
    massless = layout.n_inertial < 10 * n  # a floating base's virtual links: no columns
    Yi = np.zeros((N, n, 10 * n)) if massless else Y
    if backend == "kernel" and _rnea is None:
        raise RuntimeError("the compiled regressor kernel was not built")
    if backend != "numpy" and _rnea is not None:
        terms, axor, parents, revolute, gravity = _kernel_arrays(chain)
        _rnea.inertial_regressor(Yi, q, qd, qdd, terms, axor, parents, revolute, gravity, N, n, Yi.shape[2])
    else:
        inertial_regressor_numpy(chain, q, qd, qdd, Yi)
    if massless:
        Y[:, :, : layout.n_inertial] = Yi[:, :, list(layout.inertial_columns)]
    if include_extras:
        for c, (k, kind) in enumerate(layout.extra_columns):
            if kind in JOINT_EXTRAS:  # the motor-side ones: add_motor_columns
                Y[:, k, layout.n_inertial + c] = _joint_extra(kind, k, qd, qdd, chain.coulomb_smoothing)
    return Y


def _joint_extra(kind: str, k: int, qd: np.ndarray, qdd: np.ndarray, smoothing: float):
    """Joint k's own extra column ``kind`` (it acts on joint k's row only): q̈_k, its Coulomb
    signal, q̇_k, or 1 for the offset."""
    if kind == "rotor_inertia":
        return qdd[:, k]
    if kind == "coulomb":
        return coulomb_column(qd[:, k], smoothing)
    if kind == "viscous":
        return qd[:, k]
    return 1.0  # offset


def regressor_columns(chain: Chain, q, qd, qdd, columns, out: np.ndarray | None = None, backend: str = "auto") -> np.ndarray:
    """The chosen ``columns`` of ``regressor(chain, q, qd, qdd)`` joint-major: out[k, i, s] =
    Y[s, k, columns[i]], shape (dof, len(columns), N).

    ``out``, if given, is a C-contiguous float array (dof, w, M) with w ≥ len(columns) and M ≥ N:
    its rows [:, :len(columns), :N] are written, the rest left as they are (identify's streaming
    pass writes the base columns of its reusable row buffers this way).  Without a coupling or a
    transmission, the compiled kernel writes these rows directly, with no full regressor in
    between (tests/test_kernel.py holds both routes equal); otherwise the regressor is computed
    and its columns copied.
    """
    q, qd, qdd = (np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=float))) for x in (q, qd, qdd))
    if q.shape[1] != chain.dof or qd.shape != q.shape or qdd.shape != q.shape:
        raise ValueError(f"expected q, qd, qdd with shape (N, {chain.dof})")
    columns = np.asarray(columns, dtype=np.int64)
    N, m, layout = len(q), len(columns), chain.layout
    if out is None:
        out = np.empty((chain.dof, m, N))
    if out.ndim != 3 or out.shape[0] != chain.dof or out.shape[1] < m or out.shape[2] < N or not out.flags.c_contiguous:
        raise ValueError(f"expected a C-contiguous out of shape ({chain.dof}, >= {m}, >= {N})")
    if m and (columns.min() < 0 or columns.max() >= layout.size):
        raise ValueError(f"columns must lie in 0..{layout.size - 1}")
    direct = (backend != "numpy" and _rnea is not None and chain.coupling is None and chain.transmission is None
              and all(kind in JOINT_EXTRAS for _, kind in layout.extra_columns))
    if not direct:
        Y = regressor(chain, q, qd, qdd, backend=backend)
        out[:, :m, :N] = Y[:, :, columns].transpose(1, 2, 0)
        return out
    n = chain.n
    dest = np.full(10 * n, -1, dtype=np.int64)  # the kernel's column 10 j + c -> its row in out
    full = np.asarray(layout.inertial_columns)  # layout column i is the kernel's column full[i]
    inertial = columns < layout.n_inertial
    dest[full[columns[inertial]]] = np.flatnonzero(inertial)
    terms, axor, parents, revolute, gravity = _kernel_arrays(chain)
    assert _rnea is not None  # ``direct``: the kernel is built
    _rnea.inertial_columns(out, q, qd, qdd, terms, axor, parents, revolute, gravity, dest, N, n,
                           out.shape[1] * out.shape[2], out.shape[2])
    extras = layout.extra_columns
    for i in np.flatnonzero(~inertial):
        k, kind = extras[int(columns[i]) - layout.n_inertial]
        out[:, i, :N] = 0.0
        out[k, i, :N] = _joint_extra(kind, k, qd, qdd, chain.coulomb_smoothing)
    return out


def coulomb_column(qd: np.ndarray, smoothing: float = 0.0) -> np.ndarray:
    """The Coulomb friction signal: sign(qd), or tanh(qd / smoothing) when smoothing > 0.

    The smooth form has no jump at zero velocity (measured torque never jumps
    either: the contact deforms first); as smoothing -> 0 it tends to sign(qd).
    """
    if smoothing > 0.0:
        return np.tanh(qd / smoothing)
    return np.sign(qd)


def random_states(chain: Chain, samples: int, rng):
    """Random (q, qd, qdd) of the independent coordinates (``chain.dof``) for rank studies:
    revolute q uniform on [-pi, pi), prismatic q uniform on ±(largest length of the robot);
    rates standard normal.

    ``rng``: a seeded ``random.Random`` (what derive uses: the stdlib generator
    spares the command the ~20 ms import of numpy.random) or a numpy Generator.
    """
    sampler = getattr(chain.coupling, "random_states", None)
    if sampler is not None:  # a closed chain: states on the loops' manifold (loops/coupling.py)
        return sampler(samples, rng)
    n = chain.dof
    pris = np.array([t != REVOLUTE for t in chain.coordinate_types])
    if isinstance(rng, random.Random):
        u = _uniforms(rng, 4 * samples * n).reshape(4, samples, n)
        q = np.pi * (2.0 * u[0] - 1.0)
        # Box-Muller: two independent standard normals from two uniforms (1 - u lies in (0, 1])
        radius = np.sqrt(-2.0 * np.log1p(-u[2]))
        qd, qdd = radius * np.cos(2.0 * np.pi * u[3]), radius * np.sin(2.0 * np.pi * u[3])
        if pris.any():
            q[:, pris] = (2.0 * u[1][:, pris] - 1.0) * chain.length_scale
        return q, qd, qdd
    q = rng.uniform(-np.pi, np.pi, size=(samples, n))
    if pris.any():
        q[:, pris] = rng.uniform(-1.0, 1.0, size=(samples, int(pris.sum()))) * chain.length_scale
    qd = rng.standard_normal((samples, n))
    qdd = rng.standard_normal((samples, n))
    return q, qd, qdd


def _uniforms(rng: random.Random, count: int) -> np.ndarray:
    """``count`` uniforms on [0, 1) with 53 random bits each, from one call to the generator."""
    bits = np.frombuffer(rng.randbytes(8 * count), dtype="<u8") >> np.uint64(11)
    return bits * (1.0 / 9007199254740992.0)  # 2**-53
