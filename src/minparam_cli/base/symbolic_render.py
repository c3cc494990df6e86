"""Symbolic regrouping coefficients as sympy expressions and report fields.

Turns the exact coefficients of ``base/symbolic.py`` into, per base parameter,

* ``symbolic``: a string ``sympy.sympify`` parses back, e.g.
  ``XX2 - YY2 - a3**2*(M3 + M4 + M5 + M6)``;
* ``symbolic_text``: the same for the terminal, ``XX2 - YY2 - a3²·(M3 + M4 + M5 + M6)``;
* ``symbolic_latex``: the right-hand side in LaTeX;

plus the top-level ``symbols`` (file values, SI), ``generic_n_base``,
``symbolic_notes``, ``symbolic_verification`` and ``symbolic_latex`` (an
align* environment of the symbolic set).  sympy is imported lazily.
"""

from __future__ import annotations

import re

from minparam_cli.factoring import factor_list
from minparam_cli.base.report import Symbolic
from minparam_cli.base.symbolic_poly import exact_quotient

GREEK = {
    "alpha", "beta", "gamma", "delta", "epsilon", "theta", "phi", "psi", "rho", "sigma", "tau", "omega", "eta", "mu", "nu", "xi", "zeta", "kappa", "lambda", "chi",
}
FACTOR_TERMS = 24  # numerators with more terms are only split into content and primitive part
SUPERSCRIPTS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def symbol_latex(name: str) -> str:
    """'a3' -> 'a_{3}', 'theta2' -> '\\theta_{2}', 'shoulder_lift_y' -> '\\mathrm{shoulder\\_lift\\_y}'."""
    m = re.match(r"^([A-Za-z]+)(\d+)$", name)
    if m:
        head = "\\" + m.group(1) if m.group(1) in GREEK else (m.group(1) if len(m.group(1)) == 1 else rf"\mathrm{{{m.group(1)}}}")
        return f"{head}_{{{m.group(2)}}}"
    if len(name) == 1:
        return name
    return r"\mathrm{" + name.replace("_", r"\_") + "}"


def _names(R) -> list[str]:
    """The generators' names of a sympy ring (``str`` of a generator goes through the printer)."""
    return [s.name for s in R.symbols]


def _swapped(ctx):
    """The context's ring with each cos before its sin (normal form: cos of degree <= 1)."""
    from sympy.polys.rings import ring

    R2 = getattr(ctx, "_swapped", None)
    if R2 is None:
        names: list[str] = []
        for nm in _names(ctx.R):
            if nm.startswith("cos_"):
                names.insert(len(names) - 1, nm)  # before its sin
            else:
                names.append(nm)
        R2 = ring(",".join(names), ctx.QQ)[0]
        ctx._swapped = R2
    return R2


def _cancel_by_division(n, factors):
    """n / prod(f^e) with every factor that divides n exactly removed."""
    out = []
    for f, e in factors:
        while e:
            q = exact_quotient(n, f)
            if q is None:
                break
            n, e = q, e - 1
        if e:
            out.append((f, e))
    return n, out


def field_to_sympy(value, fs):
    """An exact number (``symbolic_poly.Frac``) as a sympy expression in the geometry symbols,
    sin_<angle>/cos_<angle> printed as sin(angle)/cos(angle).  The normal form with sin² or the
    one with cos² eliminated (numerator and each denominator factor), whichever is shorter
    after cancelling factors by exact division."""
    import sympy as sp

    value = value.cancelled()
    ctx = value.ctx
    facs = [(ctx.factors[k], e) for k, e in value.d.items()]

    def target(R):
        out = []
        for nm in _names(R):
            if nm.startswith(("sin_", "cos_")) and nm[4:] in fs.angles:
                out.append((sp.sin if nm[:3] == "sin" else sp.cos)(sp.Symbol(nm[4:])))
            else:
                out.append(sp.Symbol(nm))
        return out

    def expanded(n, fl, R):
        syms = target(R)
        den = sp.Integer(1)
        for f, e in fl:
            den *= f.as_expr(*syms) ** e
        den = _pythagoras(den)
        return n.as_expr(*syms) / den, den, syms

    def expr(n, fl, R, first):
        """Expanded and factored forms of n / prod(f^e) (full factorisation of small numerators,
        numeric and monomial content of large ones: sympy's factoring costs seconds there; a
        monomial is its own factored form)."""
        e0, den, syms = first
        out = [e0]
        if len(n.terms()) > 1:
            if len(n.terms()) <= FACTOR_TERMS:  # in the symbols present only (sympy's ring has all)
                num = _factored(n, syms)
            else:
                coeff, prim = n.primitive()
                mon = [min(m[i] for m, _ in prim.terms()) for i in range(R.ngens)]
                nf = [(R({tuple(mon): 1}), 1), (prim.exquo(R({tuple(mon): 1})), 1)] if any(mon) else [(prim, 1)]
                num = sp.Rational(coeff.numerator, coeff.denominator)
                for f, e in nf:
                    num *= f.as_expr(*syms) ** e
            out.append(_pythagoras(num / den))
        return out

    key = (tuple(sorted(value.n.items())), tuple(sorted(value.d.items())))
    cache = ctx.__dict__.setdefault("_printed", {})
    if key in cache:  # equal coefficients recur across base parameters
        return cache[key]
    forms = [(value.n, facs, ctx.R)]
    circles = [ctx.circle]
    if fs.angles:
        R2 = _swapped(ctx)
        g2 = dict(zip(_names(R2), R2.gens, strict=True))
        circle = [g2[f"sin_{a}"] ** 2 + g2[f"cos_{a}"] ** 2 - 1 for a in fs.angles]
        n2 = value.n.set_ring(R2).rem(circle)
        f2 = [(f.set_ring(R2).rem(circle), e) for f, e in facs]
        forms.append((*_cancel_by_division(n2, f2), R2))
        circles.append(circle)
    # the normal form (sin² or cos² eliminated) whose expanded form is shorter is factored, only it
    firsts = [expanded(*f) for f in forms]
    printed: dict = {}  # str() of each candidate, once: printing 10³-term expressions takes seconds

    def text(x):
        if id(x) not in printed:
            printed[id(x)] = (x, str(x))  # x kept alive, so that its id stays its own
        return printed[id(x)][1]

    best = min(range(len(forms)), key=lambda i: (len(text(firsts[i][0])), i))
    cands = expr(*forms[best], firsts[best]) + [f[0] for f in firsts]
    lengths = {*fs.lengths, *(g for g, _, _ in fs.gravity)}
    for (n, fl, R), circle, (_, _, syms) in zip(forms, circles, firsts, strict=True):
        c = _collected(n, fl, R, circle, syms, lengths)
        if c is not None:
            cands.append(c)
    out = min(cands, key=lambda x: (len(text(x)), text(x)))
    cache[key] = out
    return out


def _factored(n, syms):
    """``sympy.factor`` of the polynomial n (a ring element whose generators print as syms), the same
    expression, factored in a sparse ring instead of through sympy's expressions (the part of
    ``field_to_sympy`` that took longest on the skewed 6- and 7-joint arms).

    ``factor`` builds a Poly in the generators present, in the order of ``_sort_gens``, factors it
    over Z (each factor primitive with a positive leading coefficient in that lex order) and
    multiplies coefficient and factors with ``_keep_coeff``; the same ring order gives the same
    factors, hence the same expression."""
    import sympy as sp
    from sympy.core.mul import _keep_coeff
    from sympy.polys.polyutils import _sort_gens
    from sympy.polys.rings import ring

    present = [i for i, d in enumerate(n.degrees()) if d > 0]
    where = {syms[i]: i for i in present}
    order = [where[g] for g in _sort_gens([syms[i] for i in present])]
    Rs = ring(",".join(f"_g{k}" for k in range(len(order))), n.ring.domain)[0]
    coeff, facs = factor_list(Rs.from_dict({tuple(m[i] for i in order): c for m, c in n.items()}))
    gens = [syms[i] for i in order]
    return _keep_coeff(sp.Rational(coeff.numerator, coeff.denominator), sp.Mul(*[f.as_expr(*gens) ** k for f, k in facs]))


_FACTORS: dict = {}  # denominator factor -> factor_list (few, recurring)


def _collected(n, fl, R, circle, syms, lengths):
    """n / den as a sum over the monomials m of the lengths and gravity: Σ m · (P_m / den), each
    trigonometric quotient cancelled (the form a paper prints: a1²/sin²α1 − a2²/sin²α2 + d2²
    instead of one fraction over sin²α1·sin²α2).  None when a denominator factor holds a length
    or n has a single length monomial (nothing to collect)."""
    import sympy as sp

    idx = [i for i, nm in enumerate(_names(R)) if nm in lengths]
    if not idx or any(f.degrees()[i] for f, _ in fl for i in idx):
        return None
    groups: dict = {}
    for mon, c in n.terms():
        key = tuple(mon[i] for i in idx)
        rest = tuple(0 if i in idx else e for i, e in enumerate(mon))
        groups.setdefault(key, {})[rest] = c
    if len(groups) < 2:
        return None
    # the denominator in the same normal form as n ((cos α − 1)(cos α + 1) → −sin²α), then split
    # into irreducible factors, so exact division cancels all it can
    den = R.one
    for f, e in fl:
        den *= f**e
    den = den.rem(circle) if circle else den
    key = (R, tuple(sorted(den.items())))
    if key not in _FACTORS:
        _FACTORS[key] = factor_list(den)
    c, fl = _FACTORS[key]
    out = []
    for key, terms in groups.items():
        m = sp.Integer(1)
        for i, e in zip(idx, key, strict=True):
            m *= syms[i] ** e
        p, fl_m = _cancel_by_division(R.from_dict(terms), fl)  # irreducible factors: complete cancellation
        d = sp.Rational(c.numerator, c.denominator)
        for f, e in fl_m:
            d *= f.as_expr(*syms) ** e
        out.append(m * p.as_expr(*syms) / _pythagoras(d))
    return sp.Add(*out)


def _pythagoras(expr):
    """(sin x − 1)(sin x + 1) → −cos²x and (cos x − 1)(cos x + 1) → −sin²x among the factors of a
    product (as factor() leaves them); a structural pass over the top-level factors."""
    import sympy as sp

    if not expr.is_Mul:
        return expr
    factors = list(expr.args)
    for f in expr.atoms(sp.sin, sp.cos):
        lo, hi = f - 1, f + 1
        if lo in factors and hi in factors:
            factors.remove(lo)
            factors.remove(hi)
            other = sp.cos(f.args[0]) if isinstance(f, sp.sin) else sp.sin(f.args[0])
            factors.append(-other**2)
    return sp.Mul(*factors)


def _compact(expr):
    """The printed form is chosen in ``field_to_sympy`` (expanded or factored, whichever is shorter)."""
    return expr


def _text(s: str) -> str:
    s = re.sub(r"\*\*\((-\d+)\)", lambda m: m.group(1).translate(SUPERSCRIPTS), s)
    s = re.sub(r"\*\*(\d+)", lambda m: m.group(1).translate(SUPERSCRIPTS), s)
    return s.replace("*", "·")


def base_parameter_expressions(result) -> list[dict]:
    """One dict per base parameter of the generic set: name and its three symbolic forms."""
    import sympy as sp

    from minparam_cli.params import latex_name

    generic, coefficients, symbols = result["generic"], result["coefficients"], result["symbols"]
    exact = result.get("exact", {})
    names = generic.standard_names
    dependent = generic.dependent
    latex_symbols = {sp.Symbol(s.name): symbol_latex(s.name) for s in symbols}
    latex_symbols.update({sp.Symbol(k): symbol_latex(k) for k in result.get("gravity", {})})
    out = []
    for i, bname in enumerate(generic.base_names):
        groups: dict = {}
        for jj, col in enumerate(dependent):
            coef = coefficients.get((i, jj))
            if coef is None or coef == 0:
                continue
            value = exact.get((i, jj))
            for key, (val, params) in groups.items():  # equal coefficients share a bracket (exact test)
                if (value is not None and val is not None and not (value - val)) or key == coef:
                    params.append(names[col])
                    break
            else:
                groups[coef] = (value, [names[col]])
        head = names[generic.kept[i]]
        plain, text, tex = [head], [head], [latex_name(head)]
        for coef, (_, params) in groups.items():
            c = _compact(coef)
            neg = c.could_extract_minus_sign()
            c = -c if neg else c
            sign = " - " if neg else " + "
            body = params[0] if len(params) == 1 else "(" + " + ".join(params) + ")"
            body_tex = latex_name(params[0]) if len(params) == 1 else r"\left(" + " + ".join(latex_name(p) for p in params) + r"\right)"
            if c == 1:
                for p in params:
                    plain.append(sign + p)
                    text.append(sign + p)
                    tex.append(sign + latex_name(p))
                continue
            cs = str(c)
            ctex = sp.latex(c, symbol_names=latex_symbols)
            if isinstance(c, sp.Add):
                cs, ctex = f"({cs})", rf"\left({ctex}\right)"
            plain.append(f"{sign}{cs}*{body}")
            text.append(f"{sign}{_text(cs)}·{body}")
            tex.append(rf"{sign}{ctex}\,{body_tex}")
        out.append({"name": bname, "symbolic": "".join(plain), "symbolic_text": "".join(text), "symbolic_latex": "".join(tex)})
    return out


def latex_block(items: list[dict], comment: str) -> str:
    from minparam_cli.params import latex_name

    lines = [f"% {comment}", r"\begin{align*}"]
    for i, b in enumerate(items):
        end = r" \\" if i < len(items) - 1 else ""
        lines.append(f"  {latex_name(b['name'])} &= {b['symbolic_latex']}{end}")
    lines.append(r"\end{align*}")
    return "\n".join(lines) + "\n"


def refused_fields(reason: str, elapsed_s: float) -> Symbolic:
    """Why there is no symbolic set (the numeric set stays)."""
    return Symbolic({"symbolic_verification": {"passed": False, "refused": reason, "elapsed_s": round(elapsed_s, 6)},
                     "symbolic_notes": [f"no symbolic set: {reason}"]})


def symbolic_fields(robot: str, n_base: int, result: dict) -> Symbolic:
    """The report's symbolic fields of ``result`` (``symbolic_base``), for the file's set of ``n_base``
    base parameters of ``robot``."""
    fields: dict = {}
    parameters = None
    generic = result["generic"]
    ver = dict(result["verification"])
    notes = []
    for name, v in result["adjusted"].items():
        notes.append(f"{name} is given as {v[0]!r} rad, taken as exactly {v[1]:d} deg (a right angle, not a symbol)")
    fields["symbols"] = {s.name: s.value for s in result["symbols"]} | dict(result.get("gravity", {}))
    shifts = list(result.get("shifts", ()))
    if shifts:
        if len(shifts) == 1:
            notes.append(f"{shifts[0]} only shifts its joint's coordinate: the regrouping does not depend on it")
        else:
            notes.append(f"{', '.join(shifts)} only shift their joints' coordinates: the regrouping does not depend on them")
    if result.get("numbers"):
        fields["symbolic_numbers"] = list(result["numbers"])
        notes.append(f"exact numbers from the file, not symbols: {', '.join(result['numbers'])}")
    fields["generic_n_base"] = generic.n_base
    ver["elapsed_s"] = round(result["elapsed_s"], 6)
    fields["symbolic_verification"] = ver
    if not ver["passed"]:
        notes.append(
            f"symbolic coefficients failed verification (at fresh geometries: beta error "
            f"{ver['max_rel_error_fresh']:.3g}, identity error {ver.get('max_identity_error_fresh', float('nan')):.3g}; "
            f"at the file's values: identity error {ver['max_rel_error_file'] if ver['max_rel_error_file'] is not None else float('nan'):.3g}); "
            "not printed"
        )
        fields["symbolic_notes"] = notes
        return Symbolic(fields)
    items = base_parameter_expressions(result)
    if result["special"]:
        notes.append(
            f"special geometry: the file's values give {n_base} base parameters, generic values of the same "
            f"symbols give {generic.n_base}; 'symbolic_generic' is the generic set, 'base_parameters' the file's (numeric)"
        )
        for cond in result["conditions"]:
            notes.append(f"the rank drops when {cond}")
        if not result["conditions"]:
            notes.append("no single value or x = ±y relation of the file's symbols explains the drop alone")
        fields["symbolic_generic"] = items
        which = "generic set (not the file's: see notes)"
    else:
        parameters = tuple({k: v for k, v in s.items() if k != "name"} for s in items)
        which = "symbolic regrouping"
    fields["symbolic_notes"] = notes
    fields["symbolic_latex"] = latex_block(items, f"{robot}: {which}, {generic.n_base} base parameters")
    return Symbolic(fields, parameters)
