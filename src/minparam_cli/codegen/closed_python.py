"""NumPy emitter of a closed chain's base regressor (``codegen/closed.py``)."""

from __future__ import annotations

from minparam_cli.codegen.emit_python import _STATES, _assignments, _body, _docstring

_GLUE = '''def base_regressor(q, qd, qdd):
    """The actuated torques' base regressor Y_b (F x N_BASE): tau_a = Y_b @ beta_b.

    q, qd, qdd: (DOF,) or (N, DOF) states of every tree joint on the loops' manifold.
    """
    single = np.asarray(q).ndim == 1
    Yt = _tree_columns(q, qd, qdd)
    J = _closure_jacobian(q, qd, qdd)
    Jp, Ja = J[:, :, PASSIVE], J[:, :, ACTUATED]
    JpT = np.swapaxes(Jp, 1, 2)
    X = np.linalg.solve(JpT @ Jp, JpT @ Ja)
    Yb = Yt[:, ACTUATED, :] - np.swapaxes(X, 1, 2) @ Yt[:, PASSIVE, :]
    return Yb[0] if single else Yb
'''


def emit_closed_python(prog, fns, header: list[str], model, base) -> dict[str, str]:
    chain = model.chain
    doc = _docstring("\n".join(header + ["", "Depends on NumPy only; vectorised over samples."]))
    src = [f'"""{doc}\n"""', "", "import numpy as np", "", f"DOF = {chain.n}", f"F = {len(model.actuated)}",
           f"N_BASE = {base.n_base}", f"ACTUATED = {list(model.actuated)!r}",
           f"PASSIVE = {list(model.passive)!r}", f"BASE_NAMES = {tuple(base.base_names)!r}", "", "", _STATES]
    for f in fns:
        lines, outs = _body(prog, f.outputs, casadi=False)
        src += [f"def _{f.name}(q, qd, qdd):", f'    """{_docstring(f.doc)}: shape (N, {f.rows}, {f.cols})."""',
                "    q, qd, qdd, _ = _states(q, qd, qdd)", "    N = q.shape[0]"] + lines
        src.append(f"    {f.out_name} = np.zeros((N, {f.rows}, {f.cols}))")
        src += _assignments(outs, f.cols, lambda r, c, name=f.out_name: f"{name}[:, {r}, {c}]") + [f"    return {f.out_name}", "", ""]
    src.append(_GLUE)
    return {".py": "\n".join(src).rstrip() + "\n"}
