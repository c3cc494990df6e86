"""C99 emitter: one header and one source file, libm only, no allocation, no static state.

Every function takes q, qd, qdd (one entry per coordinate, the description's joint order) and
writes its output row-major into a caller's array; the instructions are the recorded program
(``trace.py``), one ``const double`` each, so the compiler sees a straight line it can schedule.
"""

from __future__ import annotations

from minparam_cli.codegen.trace import expressions

_CALL = {"sin": "sin({})", "cos": "cos({})", "tanh": "tanh({})", "exp": "exp({})", "abs": "fabs({})",
         "sign": "(double)(({0} > 0.0) - ({0} < 0.0))", "pos": "({} > 0.0 ? 1.0 : 0.0)", "negind": "({} < 0.0 ? 1.0 : 0.0)"}


def constant(x: float) -> str:
    """A double literal that reads back to exactly ``x`` (repr is the shortest round trip)."""
    s = repr(float(x))
    if "e" not in s and "." not in s:
        s += ".0"
    return f"({s})" if x < 0 else s


def _body(prog, outputs, out_name: str, indent: str = "    ") -> list[str]:
    assigns, outs = expressions(prog, outputs, _CALL, constant, lambda name, k: f"{name}[{k}]")
    return ([f"{indent}const double t{k} = {expr};" for k, expr in assigns]
            + [f"{indent}{out_name}[{k}] = {o};" for k, o in enumerate(outs)])


def _comment(lines: list[str]) -> str:
    body = "\n".join((" * " + ln.replace("*/", "* /")).rstrip() for ln in lines)
    return "/*\n" + body + "\n */\n"


def _names(values) -> str:
    return "{" + ", ".join('"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"' for v in values) + "}"


def emit_c(prog, fns, prefix: str, header: list[str], chain, base, full: bool, stem: str) -> dict[str, str]:
    P = prefix.upper()
    sizes = {"base_regressor": f"{P}_DOF * {P}_N_BASE", "inverse_dynamics": f"{P}_DOF",
             "regressor": f"{P}_DOF * {P}_N_STANDARD"}
    usage = [
        "",
        "C99, libm only; no allocation, no static state (reentrant, thread-safe).",
        f"Every function reads q, qd, qdd[{P}_DOF] and writes its output row-major:",
        f"  {prefix}_base_regressor: Yb[k * {P}_N_BASE + i] = dtau_k / dbeta_i.",
        f"Compile: cc -O2 -c {stem}.c   (link with -lm)",
    ]
    h = [_comment(header + usage), f"#ifndef {P}_MINPARAM_H", f"#define {P}_MINPARAM_H", "",
         "#ifdef __cplusplus", 'extern "C" {', "#endif", "",
         f"#define {P}_DOF {chain.dof}", f"#define {P}_N_BASE {base.n_base}", f"#define {P}_N_STANDARD {base.n_standard}", "",
         "/* names of the base parameters, in the order of the columns of Yb */",
         f"extern const char *const {prefix}_base_names[{P}_N_BASE];"]
    if full:
        h += ["/* names of the standard parameters, in the order of the columns of Y */",
              f"extern const char *const {prefix}_standard_names[{P}_N_STANDARD];",
              f"/* K, row-major {P}_N_BASE x {P}_N_STANDARD: beta_b = K * phi */",
              f"extern const double {prefix}_K[{P}_N_BASE * {P}_N_STANDARD];"]
    src = [_comment(header[:2]), f'#include "{stem}.h"', "", "#include <math.h>", "",
           f"const char *const {prefix}_base_names[{P}_N_BASE] = {_names(base.base_names)};", ""]
    if full:
        src += [f"const char *const {prefix}_standard_names[{P}_N_STANDARD] = {_names(base.standard_names)};", "",
                f"const double {prefix}_K[{P}_N_BASE * {P}_N_STANDARD] = {{"]
        src += ["    " + ", ".join(constant(x) for x in row) + "," for row in base.K]
        src += ["};", ""]
    for f in fns:
        sig = (f"void {prefix}_{f.name}(const double q[{P}_DOF], const double qd[{P}_DOF], const double qdd[{P}_DOF], "
               f"double {f.out_name}[{sizes[f.name]}])")
        h += ["", "/* " + f.doc.replace("*/", "* /") + " */", sig + ";"]
        # (void) casts: a robot whose function reads no q (or no q̇) still compiles under -Wextra -Werror
        src += [sig, "{", "    (void)q;", "    (void)qd;", "    (void)qdd;"] + _body(prog, f.outputs, f.out_name) + ["}", ""]
    h += ["", "#ifdef __cplusplus", "}", "#endif", "", f"#endif /* {P}_MINPARAM_H */", ""]
    return {".h": "\n".join(h), ".c": "\n".join(src)}
