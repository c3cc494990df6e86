"""Python emitters: NumPy (vectorised over samples) and CasADi (a ``casadi.Function`` of SX).

Both write the recorded program (``trace.py``) one assignment a line.  The NumPy functions take
q, qd, qdd of shape (dof,) or (N, dof) and every instruction works on all N samples at once; the
CasADi module builds its Functions once, on import, from SX symbols.
"""

from __future__ import annotations

from minparam_cli.codegen.trace import expressions

_NUMPY = {"sin": "np.sin({})", "cos": "np.cos({})", "tanh": "np.tanh({})", "exp": "np.exp({})", "abs": "np.abs({})",
          "sign": "np.sign({})", "pos": "np.greater({}, 0.0).astype(float)", "negind": "np.less({}, 0.0).astype(float)"}
_CASADI = {"sin": "ca.sin({})", "cos": "ca.cos({})", "tanh": "ca.tanh({})", "exp": "ca.exp({})", "abs": "ca.fabs({})",
           "sign": "ca.sign({})", "pos": "ca.if_else({} > 0, 1.0, 0.0)", "negind": "ca.if_else({} < 0, 1.0, 0.0)"}


def _docstring(text: str) -> str:
    """Text that cannot end a triple-quoted string or escape (file names are the user's)."""
    return text.replace("\\", "\\\\").replace('"""', "\'\'\'")


def constant(x: float) -> str:
    s = repr(float(x))
    return f"({s})" if x < 0 else s


def _body(prog, outputs, casadi: bool) -> tuple[list[str], list[str]]:
    """Assignments of the instructions, and each output's expression (a name or a constant)."""
    def element(name, k) -> str:
        return f"{name}[{k}]" if casadi else f"{name}[:, {k}]"

    assigns, outs = expressions(prog, outputs, _CASADI if casadi else _NUMPY, constant, element)
    return [f"    t{k} = {expr}" for k, expr in assigns], outs


def _assignments(outs: list[str], cols: int, target) -> list[str]:
    """One line per nonzero output entry k (row-major, ``cols`` columns): ``target(row, col) = expr``."""
    lines = []
    for k, e in enumerate(outs):
        if e != "0.0":
            r, c = divmod(k, cols)
            lines.append(f"    {target(r, c)} = {e}")
    return lines


def _numpy_function(prog, f) -> list[str]:
    lines, outs = _body(prog, f.outputs, casadi=False)
    shape = f"(N, DOF, {f.cols})" if f.cols > 1 else "(N, DOF)"
    single = f"{f.out_name}[0]"
    src = [f"def {f.name}(q, qd, qdd):", f'    """{_docstring(f.doc)}.', "",
           f"    q, qd, qdd: (dof,) or (N, dof) arrays; returns shape {shape.replace('N, ', '')} or {shape}.", '    """',
           "    q, qd, qdd, single = _states(q, qd, qdd)", "    N = q.shape[0]"]
    src += lines
    src.append(f"    {f.out_name} = np.zeros({shape})")
    src += _assignments(outs, f.cols, lambda r, c: f"{f.out_name}[:, {r}, {c}]" if f.cols > 1 else f"{f.out_name}[:, {r}]")
    src += [f"    return {single} if single else {f.out_name}", "", ""]
    return src


def _casadi_function(prog, f) -> list[str]:
    lines, outs = _body(prog, f.outputs, casadi=True)
    src = [f"def _build_{f.name}():", f'    """{_docstring(f.doc)}."""',
           '    q, qd, qdd = ca.SX.sym("q", DOF), ca.SX.sym("qd", DOF), ca.SX.sym("qdd", DOF)']
    src += lines
    src.append(f"    {f.out_name} = ca.SX({f.rows}, {f.cols})")
    src += _assignments(outs, f.cols, lambda r, c: f"{f.out_name}[{r}, {c}]")
    src += [f'    return ca.Function("{f.name}", [q, qd, qdd], [{f.out_name}], ["q", "qd", "qdd"], ["{f.out_name}"])', "", ""]
    return src


_STATES = '''def _states(q, qd, qdd):
    """Float arrays (N, DOF) and whether one state (1-D arrays) was given."""
    q, qd, qdd = (np.asarray(x, dtype=float) for x in (q, qd, qdd))
    single = q.ndim == 1
    q, qd, qdd = (np.atleast_2d(x) for x in (q, qd, qdd))
    if q.shape[1] != DOF or qd.shape != q.shape or qdd.shape != q.shape:
        raise ValueError(f"expected q, qd, qdd of shape ({DOF},) or (N, {DOF})")
    return q, qd, qdd, single


'''


def emit_python(prog, fns, header: list[str], chain, base, full: bool, casadi: bool) -> dict[str, str]:
    usage = ["", ("CasADi: every function below is a casadi.Function of (q, qd, qdd), built from SX on import."
                  if casadi else "Depends on NumPy only; every function is vectorised over samples.")]
    doc = _docstring("\n".join(header + usage))
    src = [f'"""{doc}\n"""', "", "import numpy as np"]
    if casadi:
        src += ["", "try:", "    import casadi as ca", "except ImportError as e:  # the one dependency beyond NumPy",
                "    raise ImportError(\"this module needs CasADi: pip install casadi (or 'minparam[casadi]')\") from e"]
    src += ["", f"DOF = {chain.dof}", f"BASE_NAMES = {tuple(base.base_names)!r}"]
    if full:
        src += [f"STANDARD_NAMES = {tuple(base.standard_names)!r}",
                "# beta_b = K @ phi (n_base x n_standard)",
                "K = np.array([" + ", ".join("[" + ", ".join(repr(float(x)) for x in row) + "]" for row in base.K) + "])"]
    src += ["", ""]
    if not casadi:
        src.append(_STATES)
    for f in fns:
        src += _casadi_function(prog, f) if casadi else _numpy_function(prog, f)
    if casadi:
        src += [f"{f.name} = _build_{f.name}()" for f in fns] + [""]
    return {".py": "\n".join(src).rstrip() + "\n"}
