"""C99 emitter of a closed chain's base regressor (``codegen/closed.py``): the two recorded programs
as static functions, the solve for X = (J_pᵀ J_p)⁻¹ J_pᵀ J_a by Gaussian elimination with partial
pivoting on stack arrays, libm only, no allocation, no static state."""

from __future__ import annotations

from minparam_cli.codegen.emit_c import _body, _comment, _names


def emit_closed_c(prog, fns, prefix: str, header: list[str], model, base, stem: str) -> dict[str, str]:
    P = prefix.upper()
    chain = model.chain
    n, f, nb, rows, npas = chain.n, len(model.actuated), base.n_base, fns[1].rows, len(model.passive)
    usage = ["", "C99, libm only; no allocation, no static state (reentrant, thread-safe).",
             f"{prefix}_base_regressor reads q, qd, qdd[{P}_DOF] (every tree joint, on the loops' manifold) and writes",
             f"Yb[i * {P}_N_BASE + k] = dtau_(actuated i) / dbeta_k.  Returns 0, or -1 where J_p is singular.",
             f"Compile: cc -O2 -c {stem}.c   (link with -lm)"]
    h = [_comment(header + usage), f"#ifndef {P}_MINPARAM_H", f"#define {P}_MINPARAM_H", "",
         "#ifdef __cplusplus", 'extern "C" {', "#endif", "",
         f"#define {P}_DOF {n}", f"#define {P}_N_ACTUATED {f}", f"#define {P}_N_BASE {nb}", "",
         f"extern const char *const {prefix}_base_names[{P}_N_BASE];",
         f"int {prefix}_base_regressor(const double q[{P}_DOF], const double qd[{P}_DOF], const double qdd[{P}_DOF], "
         f"double Yb[{P}_N_ACTUATED * {P}_N_BASE]);",
         "", "#ifdef __cplusplus", "}", "#endif", "", f"#endif /* {P}_MINPARAM_H */", ""]
    src = [_comment(header[:2]), f'#include "{stem}.h"', "", "#include <math.h>", "",
           f"const char *const {prefix}_base_names[{P}_N_BASE] = {_names(base.base_names)};", "",
           f"static const int actuated[{f}] = {{{', '.join(map(str, model.actuated))}}};",
           f"static const int passive[{max(npas, 1)}] = {{{', '.join(map(str, model.passive)) or '0'}}};", ""]
    for fn in fns:
        sig = (f"static void {fn.name}(const double q[{n}], const double qd[{n}], const double qdd[{n}], "
               f"double {fn.out_name}[{fn.rows * fn.cols}])")
        src += [sig, "{", "    (void)q;", "    (void)qd;", "    (void)qdd;"] + _body(prog, fn.outputs, fn.out_name) + ["}", ""]
    src += [f"int {prefix}_base_regressor(const double q[{P}_DOF], const double qd[{P}_DOF], const double qdd[{P}_DOF], "
            f"double Yb[{P}_N_ACTUATED * {P}_N_BASE])", "{",
            f"    double Yt[{n * nb}], J[{rows * n}], A[{max(npas, 1) * max(npas, 1)}], X[{max(npas, 1) * f}];",
            "    int i, j, k, r;",
            "    tree_columns(q, qd, qdd, Yt);", "    closure_jacobian(q, qd, qdd, J);",
            f"    for (i = 0; i < {npas}; ++i) {{  /* A = Jp^T Jp, X = Jp^T Ja */",
            f"        for (j = 0; j < {npas}; ++j) {{", "            double s = 0.0;",
            f"            for (r = 0; r < {rows}; ++r) s += J[r * {n} + passive[i]] * J[r * {n} + passive[j]];",
            f"            A[i * {npas} + j] = s;", "        }",
            f"        for (j = 0; j < {f}; ++j) {{", "            double s = 0.0;",
            f"            for (r = 0; r < {rows}; ++r) s += J[r * {n} + passive[i]] * J[r * {n} + actuated[j]];",
            f"            X[i * {f} + j] = s;", "        }", "    }",
            f"    for (k = 0; k < {npas}; ++k) {{  /* Gaussian elimination, partial pivoting */",
            "        int best = k;",
            f"        for (i = k + 1; i < {npas}; ++i) if (fabs(A[i * {npas} + k]) > fabs(A[best * {npas} + k])) best = i;",
            f"        if (A[best * {npas} + k] == 0.0) return -1;",
            "        if (best != k) {",
            f"            for (j = 0; j < {npas}; ++j) {{ double t = A[k * {npas} + j]; A[k * {npas} + j] = A[best * {npas} + j]; "
            f"A[best * {npas} + j] = t; }}",
            f"            for (j = 0; j < {f}; ++j) {{ double t = X[k * {f} + j]; X[k * {f} + j] = X[best * {f} + j]; "
            f"X[best * {f} + j] = t; }}", "        }",
            f"        for (i = k + 1; i < {npas}; ++i) {{",
            f"            double m = A[i * {npas} + k] / A[k * {npas} + k];",
            f"            for (j = k; j < {npas}; ++j) A[i * {npas} + j] -= m * A[k * {npas} + j];",
            f"            for (j = 0; j < {f}; ++j) X[i * {f} + j] -= m * X[k * {f} + j];", "        }", "    }",
            f"    for (k = {npas} - 1; k >= 0; --k) {{  /* back substitution */",
            f"        for (j = 0; j < {f}; ++j) {{", f"            double s = X[k * {f} + j];",
            f"            for (i = k + 1; i < {npas}; ++i) s -= A[k * {npas} + i] * X[i * {f} + j];",
            f"            X[k * {f} + j] = s / A[k * {npas} + k];", "        }", "    }",
            f"    for (i = 0; i < {f}; ++i)  /* Yb = Yt[actuated] - X^T Yt[passive] */",
            f"        for (k = 0; k < {nb}; ++k) {{",
            f"            double s = Yt[actuated[i] * {nb} + k];",
            f"            for (j = 0; j < {npas}; ++j) s -= X[j * {f} + i] * Yt[passive[j] * {nb} + k];",
            f"            Yb[i * {nb} + k] = s;", "        }",
            "    return 0;", "}", ""]
    return {".h": "\n".join(h), ".c": "\n".join(src)}
