"""An independent inverse dynamics for tests: Euler–Lagrange with exact derivatives.

tau = M(q) qdd + (dM/dt) qd - 1/2 [qdᵀ (dM/dq_k) qd]_k + dV/dq

M(q) is assembled from link Jacobians and the standard parameters about the
link frame origin (kinetic energy of a rigid body about a body point), with
its own forward kinematics written from 4x4 products.  dM/dq and dV/dq come
from the complex-step derivative f'(x) = Im f(x + i h) / h, exact to rounding
for analytic f (Squire & Trapp 1998).  Nothing here calls the package's
Newton–Euler code or its forward kinematics.
"""

from __future__ import annotations

import numpy as np

H = 1e-30


def _motion(kind, axis, q):
    T = np.eye(4, dtype=complex)
    if kind == "revolute":
        k = axis
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]], dtype=complex)
        T[:3, :3] = np.eye(3) + np.sin(q) * K + (1 - np.cos(q)) * (K @ K)
    else:
        T[:3, 3] = q * axis
    return T


def _fk(chain, q):
    """Link frames, axes and axis points for one configuration (complex-safe)."""
    n = chain.n
    frames, z, o = [], [], []
    for j in range(n):
        P = np.eye(4, dtype=complex) if chain.parents[j] < 0 else frames[chain.parents[j]]
        F = P @ chain.pre[j]
        z.append(F[:3, :3] @ chain.axes[j])
        o.append(F[:3, 3])
        frames.append(F @ _motion(chain.types[j], chain.axes[j], q[j]) @ chain.post[j])
    return frames, z, o


def _unpack(phi_j):
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = phi_j
    I = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    return I, np.array([MX, MY, MZ]), M


def mass_matrix(chain, phi, q):
    n = chain.n
    frames, z, o = _fk(chain, q)
    Mq = np.zeros((n, n), dtype=complex)
    for j in range(n):
        R, p = frames[j][:3, :3], frames[j][:3, 3]
        I, s, m = _unpack(phi[10 * j : 10 * j + 10])
        Jw = np.zeros((3, n), dtype=complex)
        Jv = np.zeros((3, n), dtype=complex)
        k = j
        while k >= 0:
            if chain.types[k] == "revolute":
                Jw[:, k] = z[k]
                Jv[:, k] = np.cross(z[k], p - o[k])
            else:
                Jv[:, k] = z[k]
            k = chain.parents[k]
        Iw = R @ I @ R.T
        sw = R @ s
        # KE = 1/2 m v.v + v.(w x s) + 1/2 w.I w  (about the frame origin)
        S = np.array([[0, -sw[2], sw[1]], [sw[2], 0, -sw[0]], [-sw[1], sw[0], 0]])
        Mq += m * Jv.T @ Jv + Jw.T @ Iw @ Jw + Jv.T @ (-S) @ Jw + Jw.T @ S @ Jv
    return Mq


def potential(chain, phi, q):
    frames, _, _ = _fk(chain, q)
    V = 0.0
    for j in range(chain.n):
        R, p = frames[j][:3, :3], frames[j][:3, 3]
        _, s, m = _unpack(phi[10 * j : 10 * j + 10])
        V = V - chain.gravity @ (m * p + R @ s)
    return V


def inverse_dynamics(chain, phi, q, qd, qdd):
    """Joint torques of the rigid-body model (no extras) at one state."""
    n = chain.n
    q = np.asarray(q, dtype=float)
    M = mass_matrix(chain, phi, q).real
    dM = np.empty((n, n, n))
    dV = np.empty(n)
    for k in range(n):
        e = np.zeros(n)
        e[k] = H
        dM[k] = mass_matrix(chain, phi, q + 1j * e).imag / H
        dV[k] = np.imag(potential(chain, phi, q + 1j * e)) / H
    Mdot = np.einsum("kij,k->ij", dM, qd)
    return M @ qdd + Mdot @ qd - 0.5 * np.einsum("kij,i,j->k", dM, qd, qd) + dV
