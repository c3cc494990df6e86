"""minparam's Panda base parameters against Gaz et al. 2019, Table III (docs/data/panda_comparison.md).

    python benchmarks/data/panda_comparison.py [--data PATH] [--keep DIR]

Runs, from the repository root, exactly the commands a user would type:

    minparam identify robots/panda.yaml DATA --no-diagnose --friction coulomb,viscous,offset --format json
        (column "minparam": default split, fit on the first 60 % of the time, selection on the next
        20 %, test on the last 20 %)
    minparam identify robots/panda.yaml DATA --validate DATA --split 1,0,0 --no-diagnose \\
        --friction coulomb,viscous,offset --format json
        (column "all data": fit on every sample; its errors are in-sample)
    minparam identify robots/panda.yaml DATA --no-diagnose --friction coulomb,viscous,offset --physical --format json
        (column "physical": every link a body, friction >= 0, the default prior (--prior auto: the
        description's nominal inertials, Gaz et al.'s p-hat); the same split as "minparam")
    minparam identify robots/panda.yaml DATA --physical [--prior none]
        (every default: the diagnosis on, --prior auto; the run --export-urdf writes; with --prior none,
        the masses the directions the data leave free get from the tie-break alone)
    minparam derive robots/panda.yaml --symbolic --format json
        (the expression of each base parameter)

DATA defaults to ../shared/data/panda-gaz2019/panda_exciting_traj_1.csv (GPL-3.0, never copied into
the repository).  The reference values are read from docs/data/panda_gaz2019_table3.md.  Prints
Markdown: the run figures (roles, samples, condition numbers, selection and test errors), the table,
a check that each of the paper's printed expressions has the same standard parameters and
coefficients as minparam's base parameter, and summary counts used in the report's prose.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DATA = Path("..") / "shared" / "data" / "panda-gaz2019" / "panda_exciting_traj_1.csv"
REFERENCE = ROOT / "docs" / "data" / "panda_gaz2019_table3.md"
ROBOT = "robots/panda.yaml"
# Gaz et al. 2019, supplementary Table VIII (the retrieved feasible parameters p̂): masses in kg and centres of
# mass in the link frames, m (c1z not given); see ../shared/data/panda-gaz2019/README.txt
GAZ_MASS = (4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522)
GAZ_COM = ((3.875e-3, 2.081e-3, None), (-3.141e-3, -2.872e-2, 3.495e-3), (2.7518e-2, 3.9252e-2, -6.6502e-2),
           (-5.317e-2, 1.04419e-1, 2.7454e-2), (-1.1953e-2, 4.1065e-2, -3.8437e-2), (6.0149e-2, -1.4117e-2, -1.0517e-2),
           (1.0517e-2, -4.252e-3, 6.1597e-2))
FRICTION = "coulomb,viscous,offset"

# Table III's rows 1..64 in order: the base parameter of minparam with the same combination
# (rows 1-43 checked against `derive --symbolic` by check_expression below), then friction.
ROWS = (["ZZR1", "XXR2", "XY2", "XZ2", "YZ2", "ZZR2", "XXR3", "XYR3", "XZ3", "YZ3", "ZZR3",
         "XXR4", "XYR4", "XZ4", "YZ4", "ZZR4", "XXR5", "XY5", "XZ5", "YZ5", "ZZR5",
         "XXR6", "XYR6", "XZ6", "YZ6", "ZZR6", "XXR7", "XY7", "XZ7", "YZ7", "ZZ7",
         "MX2", "MYR2", "MXR3", "MYR3", "MXR4", "MYR4", "MX5", "MYR5", "MXR6", "MYR6", "MX7", "MY7"]
        + [f"Fv{j}" for j in range(1, 8)] + [f"Fc{j}" for j in range(1, 8)] + [f"OFF{j}" for j in range(1, 8)])
FRICTION_TEXT = {"Fv": ("f_v", "same term f_v·q̇"), "Fc": ("f_c", "same term f_c·sign(q̇)"),
                 "OFF": ("f_o", "same constant")}


def number(text: str) -> float | None:
    text = text.strip().replace("−", "-")
    if not text or set(text) <= {"-"}:
        return None
    return float(text)


def read_reference(path: Path = REFERENCE) -> list[dict]:
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 9 or not cells[0].isdigit():
            continue
        k = int(cells[0])
        rows.append({"row": k, "printed": cells[1], "re": number(cells[2]), "re_std": number(cells[3]),
                     "p_hat": number(cells[4]), "cls": number(cells[5]), "cls_std": number(cells[6]),
                     "osi": number(cells[7]), "unit": cells[8]})
    if [r["row"] for r in rows] != list(range(1, len(ROWS) + 1)):
        raise SystemExit(f"{path}: expected rows 1..{len(ROWS)} of Table III")
    return rows


def run(args: list[str]) -> dict:
    """One CLI command from the repository root, its JSON output parsed."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.json"
        cmd = [sys.executable, "-m", "minparam_cli", *args, "--format", "json", "-o", str(out)]
        done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"minparam {' '.join(args)}: exit {done.returncode}\n{done.stderr}")
        return json.loads(out.read_text(encoding="utf-8"))


# ---------------------------------------------------------------- the paper's printed expressions

_TERM = re.compile(r"\s*([+-])?\s*(\d*\.?\d+)?\s*(?:(J(\d)([xyz]{2})|J([xyz]{2})(\d))|c(\d)([xyz])\s*m(\d)|m(\d))")


def parse_printed(expr: str) -> dict[str, float]:
    """The paper's expression as {standard parameter: coefficient}: Jixy -> XYi, cix mi -> MXi,
    mi -> Mi; a(m4 + m5) distributes a."""
    expr = expr.replace("−", "-")
    out: dict[str, float] = {}

    def add(name: str, c: float) -> None:
        out[name] = out.get(name, 0.0) + c

    def terms(text: str, factor: float) -> None:
        pos = 0
        while pos < len(text):
            if not text[pos:].strip():
                return
            group = re.match(r"\s*([+-])?\s*(\d*\.?\d+)?\s*\(([^)]*)\)", text[pos:])
            if group:
                sign = -1.0 if group.group(1) == "-" else 1.0
                coef = float(group.group(2)) if group.group(2) else 1.0
                terms(group.group(3), factor * sign * coef)
                pos += group.end()
                continue
            m = _TERM.match(text, pos)
            if not m:
                raise ValueError(f"cannot read {text[pos:]!r} in {expr!r}")
            sign = -1.0 if m.group(1) == "-" else 1.0
            coef = float(m.group(2)) if m.group(2) else 1.0
            c = factor * sign * coef
            if m.group(3):
                link, axes = (m.group(4), m.group(5)) if m.group(4) else (m.group(7), m.group(6))
                add(f"{axes.upper()}{link}", c)
            elif m.group(8):
                if m.group(8) != m.group(10):
                    raise ValueError(f"first moment c{m.group(8)} with mass m{m.group(10)} in {expr!r}")
                add(f"M{m.group(9).upper()}{m.group(8)}", c)
            else:
                add(f"M{m.group(11)}", c)
            pos = m.end()

    terms(expr, 1.0)
    return {k: v for k, v in out.items() if v != 0.0}


def check_expression(printed: str, terms: dict[str, float]) -> str | None:
    """None when the printed expression has minparam's standard parameters and coefficients (within
    the rounding of a 4-digit print), else what differs."""
    paper = parse_printed(printed)
    ours = {k: v for k, v in terms.items() if abs(v) > 1e-9}
    diffs = []
    for name in sorted(set(paper) | set(ours)):
        a, b = paper.get(name, 0.0), ours.get(name, 0.0)
        if abs(a - b) > 5e-4 + 5e-3 * abs(b):
            diffs.append(f"{name}: printed {a:.4g}, minparam {b:.4g}")
    return "; ".join(diffs) or None


# ---------------------------------------------------------------- formatting

def fmt_pm(value: float, std_percent: float | None) -> str:
    s = f"{value:+.4f}"
    return s if std_percent is None else f"{s} ± {std_percent:.1f}%"


def rel(x: float, ref: float) -> float:
    return abs(x - ref) / abs(ref) if ref else float("inf")


def fmt_err(e: dict) -> str:
    joints = " ".join(f"{x:.3f}" for x in e["rms_per_joint"])
    return f"rms per joint {joints} N·m, total {e['rms_total']:.4f} N·m, ‖r‖/‖τ‖ {100 * e['relative_error']:.3f} %"


def physical_section(d: dict, ref: list[dict], default: dict, bare: dict) -> None:
    """The physically consistent fit against the authors' feasible estimates: π(p̂) (their retrieved
    parameters, Tables VIII-IX) and π̂_OSI (their one-step physically consistent identification).
    ``d``: the declared model (--no-diagnose); ``default``: `identify --physical` with every default
    (diagnosis on, --prior auto: the description's inertials, Gaz et al.'s p̂), the run an export
    writes; ``bare``: the same with --prior none."""
    print("## Physically consistent fit\n")
    for label, r in (("default run", default), ("declared model (--no-diagnose)", d), ("default run, --prior none", bare)):
        p = r["physical"]
        print(f"* {label}: solver {p['solver']}, {p['status']}, {p['elapsed_s']:.2f} s; prior {p['prior']}"
              + (f", weight {p['prior_weight']:g}" if p["prior_weight"] else ""))
        print(f"  * selection data: unconstrained {fmt_err(r['after'])}")
        print(f"  * selection data: physical {fmt_err(p['selection'])}")
        for k, e in p["test"].items():
            print(f"  * test data ({k}): unconstrained {fmt_err(r['test']['final'])}")
            print(f"  * test data ({k}): physical {fmt_err(e)} "
                  f"({100 * (e['relative_error'] / r['test']['final']['relative_error'] - 1):+.1f} %)")
        for f in r["flags"]:
            if f.startswith("physical"):
                print(f"  * flag: {f}")
    print()
    print("| link | mass kg (Gaz p̂) | mass kg (minparam, default) | ratio | data-set directions | source of the 10 directions | "
          "min eig J | mass kg (declared model) | ratio | mass kg (default, --prior none) | centre of mass m (minparam, default) | "
          "centre of mass m (Gaz p̂) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for b, db, nb, m, c in zip(default["physical"]["links"], d["physical"]["links"], bare["physical"]["links"], GAZ_MASS, GAZ_COM):
        gaz_c = " ".join("n/a" if x is None else f"{x:+.4f}" for x in c)
        src = " + ".join(f"{k} {v}" for k, v in b["source"].items() if v)
        nsrc = "" if nb["fixed"] else " (not fixed)"
        print(f"| {b['link']} | {m:.4f} | {b['mass']:.4f} | {b['mass'] / m:.2f} | {b['informed_directions']}/10 | {src} | "
              f"{b['pseudo_inertia_min_eig']:.2g}{' (boundary)' if b['on_boundary'] else ''} | {db['mass']:.4f} | "
              f"{db['mass'] / m:.2f} | {nb['mass']:.3g}{nsrc} | {' '.join(f'{x:+.4f}' for x in b['com'])} | {gaz_c} |")
    p = d["physical"]
    print()
    print("| parameter | physical | unconstrained (WLS) | Gaz π(p̂) | Gaz OSI | Gaz CLS |")
    print("|---|---|---|---|---|---|")
    both = {**p["base_parameters"], **{k: v for k, v in p["phi"].items()}}
    closer = {"physical": 0, "unconstrained": 0}
    for name, r in zip(ROWS, ref):
        v = both.get(name)
        w = d["parameters"][name]["value"]
        ph = "–" if r["p_hat"] is None else f"{r['p_hat']:+.4f}"
        osi = "–" if r["osi"] is None else f"{r['osi']:+.4f}"
        print(f"| {name} | {v:+.4f} | {w:+.4f} | {ph} | {osi} | {r['cls']:+.4f} |")
        if r["osi"] is not None:
            closer["physical" if abs(v - r["osi"]) < abs(w - r["osi"]) else "unconstrained"] += 1
    print()
    print(f"* nearer to Gaz OSI: physical {closer['physical']}, unconstrained {closer['unconstrained']} "
          f"(of {sum(closer.values())} parameters with an OSI value)")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA), help="the recording, relative to the repository root")
    ap.add_argument("--keep", type=Path, help="also write the three JSON outputs into this folder")
    args = ap.parse_args()
    data = args.data
    ref = read_reference()
    common = ["--no-diagnose", "--friction", FRICTION]
    split = run(["identify", ROBOT, data, *common])
    whole = run(["identify", ROBOT, data, "--validate", data, "--split", "1,0,0", *common])
    phys = run(["identify", ROBOT, data, *common, "--physical"])
    default = run(["identify", ROBOT, data, "--physical"])
    bare = run(["identify", ROBOT, data, "--physical", "--prior", "none"])
    derive = run(["derive", ROBOT, "--symbolic"])
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
        for name, d in (("split", split), ("all_data", whole), ("physical", phys), ("physical_default", default),
                        ("physical_no_prior", bare),
                        ("derive", derive)):
            (args.keep / f"{name}.json").write_text(json.dumps(d, indent=1), encoding="utf-8")
    base = {b["name"]: b for b in derive["base_parameters"]}

    print("## Runs\n")
    print("```")
    print(f"minparam identify {ROBOT} {data} --no-diagnose --friction {FRICTION}            # column \"minparam\"")
    print(f"minparam identify {ROBOT} {data} --validate {data} --split 1,0,0 --no-diagnose --friction {FRICTION}"
          "  # column \"all data\"")
    print(f"minparam identify {ROBOT} {data} --no-diagnose --friction {FRICTION} --physical  # column \"physical\", \"declared model\"")
    print(f"minparam identify {ROBOT} {data} --physical  # \"default\": every default (diagnosis, --prior auto)")
    print(f"minparam identify {ROBOT} {data} --physical --prior none  # \"default, --prior none\"")
    print(f"minparam derive {ROBOT} --symbolic --format json  # expressions")
    print("```\n")
    for label, d in (("minparam (default split)", split), ("all data", whole)):
        roles = {k: [(p["source"], p["time_s"]) for p in v] for k, v in d["roles"].items()}
        print(f"* {label}: split {d['split']}, samples fit {d['samples_fit']}, selection {d['samples_selection']}, "
              f"test {d['samples_test']}; dropped {d['dropped']}; {d['method'].upper()}, condition number "
              f"{d['condition_number']:.2f} (column-scaled {d['condition_number_scaled']:.2f}); roles {roles}")
        print(f"  * before/after on the {d['before']['data']} data: {fmt_err(d['after'])}")
        if d["test"]["final"]:
            print(f"  * test data: {fmt_err(d['test']['final'])}")
        for f in d["flags"]:
            print(f"  * flag: {f}")
    print()

    print("## Table\n")
    print("| parameter | minparam | all data | Gaz CLS | Gaz R−E | Δ vs CLS | matching expression |")
    print("|---|---|---|---|---|---|---|")
    stats = []
    for name, r in zip(ROWS, ref):
        m, w = split["parameters"][name], whole["parameters"][name]
        sigma = abs(m["value"]) * m["std_percent"] / 100
        delta = m["value"] - r["cls"]
        z = delta / sigma if sigma else float("inf")
        if name in base:
            expr = f"{name} = {base[name]['symbolic_text']}"
            mismatch = check_expression(r["printed"], base[name]["terms"])
        else:
            kind, j = re.match(r"([A-Za-z]+)(\d)", name).groups()
            sym, words = FRICTION_TEXT[kind]
            expr, mismatch = f"{sym},{j} ↔ {name}: {words}", None
        re_txt = "–" if r["re"] is None else f"{r['re']:+.4f}"
        print(f"| {name} | {fmt_pm(m['value'], m['std_percent'])} | {fmt_pm(w['value'], w['std_percent'])} | "
              f"{r['cls']:+.4f} ± {r['cls_std']:g}% | {re_txt} | {delta:+.4f} ({z:+.1f}σ) | {expr} |")
        stats.append({"name": name, "row": r["row"], "m": m["value"], "m_std": m["std_percent"], "w": w["value"],
                      "cls": r["cls"], "re": r["re"], "p_hat": r["p_hat"], "z": z, "mismatch": mismatch})
    print()

    physical_section(phys, ref, default, bare)

    print("## Checks and counts\n")
    bad = [(s["row"], s["name"], s["mismatch"]) for s in stats if s["mismatch"]]
    n_rigid = sum(1 for s in stats if s["name"] in base)
    print(f"* expressions: {n_rigid - len(bad)} of {n_rigid} printed rows have minparam's standard parameters and "
          "coefficients (within the 4-digit print)" + "".join(f"; row {k} ({n}) differs: {why}" for k, n, why in bad))

    def count(group: list[dict], label: str) -> None:
        n = len(group)
        zs = [abs(s["z"]) for s in group]
        rs = [rel(s["m"], s["cls"]) for s in group]
        sign = sum(1 for s in group if (s["m"] > 0) == (s["cls"] > 0))
        closer = [s for s in group if s["re"] is not None]
        inside = sum(1 for s in closer if abs(s["m"] - s["cls"]) <= abs(s["re"] - s["cls"]))
        print(f"* {label} ({n}): within 1σ {sum(z <= 1 for z in zs)}, 2σ {sum(z <= 2 for z in zs)}, "
              f"3σ {sum(z <= 3 for z in zs)} (minparam's σ); within 5 % of CLS {sum(x <= .05 for x in rs)}, "
              f"10 % {sum(x <= .10 for x in rs)}, 25 % {sum(x <= .25 for x in rs)}; same sign as CLS {sign}"
              + (f"; no farther from CLS than R−E is {inside} of {len(closer)}" if closer else ""))

    rigid = [s for s in stats if s["name"] in base]
    count(stats, "all parameters")
    count(rigid, "rigid-body base parameters")
    count([s for s in rigid if abs(s["cls"]) >= 0.05], "rigid-body, |CLS| ≥ 0.05")
    count([s for s in rigid if abs(s["cls"]) < 0.05], "rigid-body, |CLS| < 0.05")
    count([s for s in stats if s["name"] not in base], "friction")
    for kind in ("Fv", "Fc", "OFF"):
        count([s for s in stats if re.fullmatch(kind + r"\d", s["name"])], kind)
    print("* relative difference to CLS, largest rigid-body terms (|CLS| ≥ 0.05): "
          + ", ".join(f"{s['name']} {100 * (s['m'] - s['cls']) / s['cls']:+.1f} % ({s['m']:.4f} vs {s['cls']:.4f}, "
                      f"R−E {s['re']:.4f}, {s['z']:+.1f}σ)" for s in rigid if abs(s["cls"]) >= 0.05))
    for group, label in ((rigid, "rigid-body"), ([s for s in rigid if abs(s["cls"]) >= 0.05], "|CLS| ≥ 0.05")):
        near: dict[str, list[str]] = {"CLS": [], "R−E": [], "π(p̂)": []}
        for s in group:
            refs = {"CLS": s["cls"], "R−E": s["re"], "π(p̂)": s["p_hat"]}
            best = min((k for k, v in refs.items() if v is not None), key=lambda k: abs(s["m"] - refs[k]))
            near[best].append(s["name"])
        between = [s["name"] for s in group if min(s["cls"], s["re"]) <= s["m"] <= max(s["cls"], s["re"])]
        print(f"* {label}: the paper's value nearest to minparam's: "
              + "; ".join(f"{k} {len(v)} ({', '.join(v)})" for k, v in near.items())
              + f"; minparam between CLS and R−E: {len(between)} ({', '.join(between)})")
    print("* all data vs minparam, |CLS| ≥ 0.05: "
          + ", ".join(f"{s['name']} {100 * (s['w'] - s['m']) / abs(s['m']):+.1f} %" for s in rigid
                      if abs(s["cls"]) >= 0.05))
    print("* friction, minparam / all data / CLS: "
          + "; ".join(f"{s['name']} {s['m']:+.3f} / {s['w']:+.3f} / {s['cls']:+.3f} ({100 * (s['m'] - s['cls']) / abs(s['cls']):+.0f} %)"
                      for s in stats if s["name"] not in base))
    print("* sign differs from CLS: " + ", ".join(
        f"{s['name']} {s['m']:+.4f} vs {s['cls']:+.4f} (all data {s['w']:+.4f}, R−E "
        + ("–" if s["re"] is None else f"{s['re']:+.4f}") + ")"
        for s in stats if (s["m"] > 0) != (s["cls"] > 0)))


if __name__ == "__main__":
    main()
