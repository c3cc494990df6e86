"""Generated code of a closed chain's base regressor (docs/methods/closed_chains.md, "Generated code").

The function takes the state of every joint of the spanning tree (q, q̇, q̈ on the loops' manifold,
the description's joint order) and returns the actuated torques' base regressor

    Y_b = Gᵀ · Y_tree[:, kept] = Y_tree[a, kept] − Xᵀ · Y_tree[p, kept],   X = (J_pᵀ J_p)⁻¹ J_pᵀ J_a

(G's passive rows are −X: ``loops/model.py``).  Two straight-line programs are recorded on one
``Program`` (the tree's Newton–Euler columns, ``programs.record_regressor``, and the closure
Jacobian J(q) from the link poses, traced here); the small symmetric solve for X is written out by
hand in each language (NumPy: ``np.linalg.solve``; C: Gaussian elimination with partial pivoting on
the stack, no allocation).
"""

from __future__ import annotations

from typing import Any

from minparam_cli.chain import REVOLUTE
from minparam_cli.codegen.functions import Function, Generated, Meta, header_lines
from minparam_cli.codegen.programs import _cross, _snap, base_columns, record_regressor
from minparam_cli.codegen.trace import Program


def closure_jacobian(prog: Program, model, q: list) -> list[list[Any]]:
    """J(q) (3m rows × n) of the closure point pairs, traced: world frames of every link from the
    chain's local terms, then per point P on body b and joint j carrying b: z_j × (P − o_j) (revolute)
    or z_j (prismatic), body a's columns minus body b's."""
    chain = model.chain
    L = chain.length_scale
    R: list[list[list[Any]]] = []
    t: list[list[Any]] = []
    z: list[list[Any]] = []
    o: list[list[Any]] = []
    for j, ((C0, C1, C2), axis, origin) in enumerate(chain.local_terms):
        if chain.types[j] == REVOLUTE:
            sn, cs = prog.call("sin", q[j]), prog.call("cos", q[j])
            Lm = [[_snap(C0[r][c] + C2[r][c], L if c == 3 else 1.0) + sn * _snap(C1[r][c]) - cs * _snap(C2[r][c])
                   for c in range(4)] for r in range(3)]
        else:
            Lm = [[_snap(C0[r][c], L if c == 3 else 1.0) + q[j] * _snap(C1[r][c]) for c in range(4)] for r in range(3)]
        p = chain.parents[j]
        ax, org = [_snap(x) for x in axis], [_snap(x, L) for x in origin]
        if p < 0:
            R.append([row[:3] for row in Lm])
            t.append([Lm[r][3] for r in range(3)])
            z.append(ax)
            o.append(org)
            continue
        Rp, tp = R[p], t[p]
        R.append([[sum((Rp[r][k] * Lm[k][c] for k in range(3)), 0.0) for c in range(3)] for r in range(3)])
        t.append([sum((Rp[r][k] * Lm[k][3] for k in range(3)), 0.0) + tp[r] for r in range(3)])
        z.append([sum((Rp[r][k] * ax[k] for k in range(3)), 0.0) for r in range(3)])
        o.append([sum((Rp[r][k] * org[k] for k in range(3)), 0.0) + tp[r] for r in range(3)])
    rows: list[list[Any]] = []
    for i in range(len(model.body_a)):
        cols: list[list[Any]] = [[0.0, 0.0, 0.0] for _ in range(chain.n)]
        for body, point, sign in ((int(model.body_a[i]), model.point_a[i], 1.0), (int(model.body_b[i]), model.point_b[i], -1.0)):
            if body < 0:
                continue
            pt = [_snap(x, L) for x in point]
            P = [sum((R[body][r][k] * pt[k] for k in range(3)), 0.0) + t[body][r] for r in range(3)]
            for j in chain.ancestors(body):
                col = _cross(z[j], [P[r] - o[j][r] for r in range(3)]) if chain.types[j] == REVOLUTE else z[j]
                cols[j] = [cols[j][r] + sign * col[r] for r in range(3)]
        rows += [[cols[j][r] for j in range(chain.n)] for r in range(3)]
    return rows


def closed_functions(model, base) -> tuple[Program, list[Function]]:
    rec = record_regressor(model.chain)
    n, nb = model.chain.n, base.n_base
    Yt = base_columns(rec, base.kept)
    J = closure_jacobian(rec.prog, model, rec.q)
    return rec.prog, [Function("tree_columns", f"Y_tree's kept columns (n x n_base = {n} x {nb}): every tree joint's torque",
                               "Yt", n, nb, [x for row in Yt for x in row]),
                      Function("closure_jacobian", f"J (3m x n = {len(J)} x {n}): the cut points' velocity per joint rate",
                               "J", len(J), n, [x for row in J for x in row])]


def generate_closed_code(model, base, lang: str, prefix: str, meta: Meta, stem: str | None = None) -> Generated:
    """The files of ``lang`` ("c" or "python") for a closed chain's base regressor."""
    prog, fns = closed_functions(model, base)
    counts = {f.name: prog.counts(f.outputs) for f in fns}
    header = header_lines(model.chain, base, meta, counts, None, False, ())
    chain = model.chain
    header[2:3] = [f"Robot: {chain.name}, a closed chain: {chain.n} tree joints ({', '.join(chain.joint_names)}), "
                   f"actuated {', '.join(chain.joint_names[j] for j in model.actuated)}, gravity {[float(g) for g in chain.gravity]} m/s^2"]
    header[4:5] = ["Inputs: q, qd, qdd of every tree joint, on the loops' manifold (the description's joint order, SI);",
                   "base_regressor returns the actuated torques' base regressor (f x n_base): tau_a = Yb * beta_b."]
    if lang == "c":
        from minparam_cli.codegen.closed_c import emit_closed_c

        files = emit_closed_c(prog, fns, prefix, header, model, base, stem or prefix)
    elif lang == "python":
        from minparam_cli.codegen.closed_python import emit_closed_python

        files = emit_closed_python(prog, fns, header, model, base)
    else:
        from minparam_cli.errors import UnsupportedError

        raise UnsupportedError(f"codegen --lang {lang} of a closed chain: not supported (use c or python)")
    return Generated(files, counts, tuple(base.base_names), (), ())

