"""Golden outputs of the documented commands, to prove that a refactor changes none of them.

    python benchmarks/same_outputs.py capture OUTDIR [--python PY] [--src SRCDIR] [--root ROOT] [--only TEXT]
    python benchmarks/same_outputs.py compare DIR_A DIR_B

capture runs each case of CASES as `PY -m minparam_cli ...` (PY: this interpreter; PYTHONPATH=SRCDIR
with --src) in cwd ROOT (default: the folder above this script), so robot paths stay relative as in
the docs. Each case gets a fresh scratch folder, `{out}` in its commands (-o, --truth, --save-model
write there); its setup commands (simulate a recording, ...) run first in the same folder. In all
that is saved the scratch path becomes `<OUT>` and ROOT `<ROOT>`, so captures of two worktrees
compare. OUTDIR/CASE/ gets cmd.txt, stdout.txt, stderr.txt (all of it), stderr_last.txt (its last
line), exit_code.txt and files/ (every file left in the scratch folder). OUTDIR/_capture.json holds
the timings and is never compared. Only shipped files are read (robots/, robots/platforms/,
benchmarks/data/symbolic/); the tx40 recording case needs ROOT/../shared/data/staubli-tx40.

compare prints case -> same/different (with a short unified diff), exit 1 if any differ. Everything
is byte-identical but for these normalizations, applied to both sides:
  * timings: the values of the JSON keys TIMING_KEYS (`elapsed_s`; `exact_s`, the symbolic
    verification's time; `cpu_s` of excite) become <T>; `time_unit`, `time_s` (a data span) and
    `time_not_increasing` are not timings and stay. Text lines: the fragments of TIMING_LINES (derive's
    `elapsed`, platform's `seed N, T s`, codegen's `generated in`, identify's `elapsed`) become <T>,
    and the `time s` column of derive's batch table is blanked;
  * the version string `minparam X.Y.Z` (codegen headers);
  * the `"schema": "minparam.<command>/N"` key every JSON result gained in issue 30 (ADDED_KEYS);
  * identify cases (name starting with `identify`): JSON outputs (stdout, --save-model) are parsed,
    timing keys dropped, numbers compared to 1e-12 relative (abs floor 1e-300), the rest exactly;
  * binary files (.npz, .png): byte for byte (simulate's .npz members have a fixed 1980 date).
"""
import argparse
import contextlib
import difflib
import functools
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TIMING_KEYS = ("elapsed_s", "exact_s", "cpu_s")
ADDED_KEYS = ("schema",)  # issue 30: every JSON result now names its schema version (first key); the rest must match
SCHEMA = re.compile(r'"schema": "minparam\.[\w.-]+/\d+",\s*')
TIMING_LINES = [  # (regex, replacement) on each text line
    (re.compile(r"(; elapsed )\d+(\.\d+)? s$"), r"\1<T> s"),            # derive table, identify
    (re.compile(r"^(seed -?\d+, )\d+(\.\d+)? s$"), r"\1<T> s"),       # platform fk / workspace
    (re.compile(r"(, generated in )\d+(\.\d+)? s"), r"\1<T> s"),       # codegen summary (stderr)
    (re.compile(r"^(Physically consistent fit \([^,]*, [^,]*, )\d+(\.\d+)? s;"), r"\1<T> s;"),
]
VERSION = re.compile(r"minparam \d+\.\d+\.\d+[\w.+-]*")
P2, P3, SC = "robots/planar2r.yaml", "robots/planar3r.yaml", "robots/scara.yaml"
PUMA, MDH, UR5U, UR5Y = "robots/puma560.yaml", "robots/puma560_mdh.yaml", "robots/ur5.urdf", "robots/ur5.yaml"
DANG, TRUSS = "robots/dodekapod_dang2013.yaml", "robots/platforms/dodekapod_truss.yaml"
SYM = "benchmarks/data/symbolic/"
L6 = "238.6357,269.3776,256.0046,247.4046,185.4388,190.2705"
L12 = "155.8634338,155.8,155.8634338,135.8749425,140.1142391,142.2040787,217.0069123,218.4765434,223.8803475,220.1613272,220.3733423,214.7738578"
Q6 = "--q 10,-30,40,20,30,15"


def sim(name="sim.csv", seed=1, duration=8):  # the simulated PUMA recording of docs/commands/codegen.md, shorter
    return f"simulate {MDH} --effects coulomb,viscous --noise 0.02 --duration {duration} --seed {seed} -o {{out}}/{name} -q"


def c(cmd: str, *setup: str):  # (arguments after `-m minparam_cli`, setup commands run first in the same scratch folder)
    return shlex.split(cmd), [shlex.split(s) for s in setup]


SAVE = f"identify {MDH} {{out}}/sim.csv -q --save-model {{out}}/model.json"
CASES = {  # case name (stable: the folder name) -> c(command, setup...)
    **{f"derive_{Path(r).name.replace('.', '_')}_table": c(f"derive {r}") for r in (MDH, PUMA, UR5U, "robots/tx40.yaml")},
    **{f"derive_planar2r_{f}": c(f"derive {P2} --format {f}") for f in ("json", "markdown", "latex")},
    "derive_iiwa14_urdf_json": c("derive robots/iiwa14.urdf --format json"),
    "derive_two_robots": c(f"derive {P2} {SC}"),
    **{f"derive_robots_dir_{k}": c(f"derive robots/{a}") for k, a in (("table", ""), ("jsonl", " --format jsonl"))},
    **{f"derive_{k}_projection{j}": c(f"derive robots/{k}.yaml --method projection{a}") for k, j, a in
       (("puma560", "", ""), ("stanford", "_json", " --format json"), ("tx40", "_refused", ""))},
    "derive_mdh_friction_rotor": c(f"derive {MDH} --friction coulomb,viscous --rotor-inertia"),
    "derive_panda_friction_offset_json": c("derive robots/panda.yaml --friction coulomb,viscous,offset --rotor-inertia --format json"),
    "derive_planar3r_gravity_samples_seed": c(f"derive {P3} --gravity 0,0,-9.81 --samples 50 --seed 3 --format json"),
    **{f"derive_{k}_symbolic": c(f"derive {a} --symbolic") for k, a in
       (("planar2r", P2), ("scara_json", f"{SC} --format json"), ("puma560", PUMA))},
    "derive_universal15_offset_rotor_symbolic": c("derive robots/universal15_glazunov.yaml --friction offset --rotor-inertia --symbolic"),
    "derive_mimic_gripper_symbolic": c(f"derive {SYM}mimic_gripper.urdf --symbolic"),
    "derive_oblique_symbolic_numbers": c(f"derive {SYM}oblique_axis.urdf --symbolic-numbers"),
    # issue 34: the skewed arms of bench_symbolic.py (DH/MDH, prismatic joints, offsets, 4 to 7 joints)
    **{f"derive_{Path(f).stem}_symbolic_json": c(f"derive {SYM}{f} --symbolic --format json") for f in (
       "skew4r_dh.yaml", "skew6r_dh.yaml", "skew_rrpr_mdh.yaml", "skew_rprr_dh.yaml", "skew_rprr_mdh.yaml", "skew_rrprr_dh.yaml",
       "skew_rprrrr_mdh.yaml", "skew_rprrpr_dh.yaml", "skew_rrprrrp_dh.yaml", "skew_prrrprr_mdh.yaml")},
    **{f"derive_{k}": c(f"derive {SYM}{a}") for k, a in (("mimic_gripper", "mimic_gripper.urdf"), ("biped_floating_root",
       "biped_floating.urdf"), ("mimic_gripper_fixed", "mimic_gripper.urdf --mimic fixed"))},
    "derive_ur5_floating_base_json": c(f"derive {UR5U} --floating-base --format json"),
    "derive_ur5_floating_projection_refused": c(f"derive {UR5U} --floating-base --method projection"),
    "derive_skew4r_snap_angles": c(f"derive {SYM}skew4r_dh.yaml --snap-angles 1e-4"),
    "derive_output_file": c(f"derive {P2} --format markdown -o {{out}}/planar2r.md"),
    **{f"derive_error_{k}": c(f"derive {a}") for k, a in (("missing_file", "robots/no_such_robot.yaml"),
       ("not_a_robot", "README.md"), ("bad_method", f"{P2} --method svd"))},
    **{f"check_robots_dir{k}": c(f"check robots/{a}") for k, a in (("", ""), ("_json", " --json"))},
    **{f"check_{k}": c(f"check {a}") for k, a in (("tx40_json", "robots/tx40.yaml --json"), ("symbolic_dir", SYM),
                                                  ("error_bad_file", "pyproject.toml"))},
    **{f"codegen_puma560_{lang}": c(f"codegen {PUMA} --lang {lang} -o {{out}}/{f}") for lang, f in
       (("c", "puma.c"), ("python", "puma_np.py"), ("casadi", "puma_ca.py"))},
    "codegen_ur5_urdf_python_full": c(f"codegen {UR5U} --lang python --full -o {{out}}/ur5_np.py"),
    "codegen_panda_c_name_friction": c("codegen robots/panda.yaml --lang c --name arm --friction coulomb,viscous --rotor-inertia -o {out}/arm.c"),
    "codegen_planar2r_python_stdout": c(f"codegen {P2} --lang python"),
    **{f"codegen_error_{k}": c(f"codegen {PUMA} --lang {a}") for k, a in (("c_without_o", "c"), ("bad_lang", "rust -o {out}/x.rs"))},
    **{f"singular_ur5_urdf{k}": c(f"singular {UR5U} {Q6}{a}") for k, a in
       (("", ""), ("_tool_wrist3", " --tool wrist_3_link"), ("_tool_world_error", " --tool world"))},
    "singular_ur5_yaml_tool_error": c(f"singular {UR5Y} {Q6} --tool ee_link"),
    "singular_iiwa14_tool_link3": c("singular robots/iiwa14.urdf --q 10,-30,40 --tool iiwa_link_3"),
    "singular_puma560_twist": c(f"singular {PUMA} --q 10,-30,40,20,0,15 --twist 0.1,0.2,0.3,0.1,0.1,0.1"),
    "singular_puma560_near": c(f"singular {PUMA} --q 10,-30,92.6836,20,30,15"),
    **{f"singular_ur5_yaml_groups{k}": c(f"singular {UR5Y} --q 0,0,0,90,0,0{a}") for k, a in (("", ""), ("_json", " --format json"))},
    "singular_puma560_scan": c(f"singular {PUMA} --q 0,0,0,0,30,0 --scan"),
    "singular_puma560_scan_plot_json": c(f"singular {PUMA} --q 0,0,0,0,30,0 --scan --step 30 --plot {{out}}/map.png --joints 2,3 --format json"),
    "singular_puma560_symbolic": c(f"singular {PUMA} --symbolic"),
    "singular_universal15_json": c("singular robots/universal15_glazunov.yaml --q 0,0,0,0.4,0,0 --twist 0.1,0.1,0.2,0.2,0.4,0.4 --format json"),
    "singular_puma560_hold_damping": c(f"singular {PUMA} --q 0,0,0,0,0,0 --twist 0,0,1,0.1,0,0 --hold 4 --damping 0.1"),
    "singular_stanford_rad_output": c("singular robots/stanford.yaml --q 0.1,0.2,0.3,0.4,0.5,0.6 --rad -o {out}/stanford.txt"),
    **{f"singular_error_{k}": c(f"singular {PUMA} --q {a}") for k, a in (("wrong_count", "1,2,3"),
       ("hold_loses_rank", "0,0,0,0,0,0 --hold 1"), ("short_twist", "0,0,0,0,0,0 --twist 1,2,3"))},
    **{f"platform_fk_dang{k}": c(f"platform fk {DANG} --lengths {L6}{a}") for k, a in
       (("", ""), ("_json", " --format json"), ("_pso", " --method pso --seed 2"))},
    "platform_fk_equilateral": c(f"platform fk robots/platforms/dodekapod_dang2013_equilateral.yaml --lengths {L6}"),
    "platform_ik_dang_pose": c(f"platform ik {DANG} --pose 10,-5,200,5,-3,20"),
    "platform_ik_dang_normal_json": c(f"platform ik {DANG} --position 0,0,200 --normal 0.1,0,1 --yaw 10 --format json"),
    "platform_ik_truss_json": c(f"platform ik {TRUSS} --format json"),
    "platform_fk_truss": c(f"platform fk {TRUSS} --frame B1,B2,B3 --lengths {L12}"),
    "platform_ik_hexapod": c("platform ik robots/platforms/hexapod_6_6.yaml --pose 0,0,0,0,0,0"),
    "platform_workspace_dang_plot": c(f"platform workspace {DANG} --samples 20000 --plot {{out}}/ws.png"),
    "platform_workspace_dang_json_file": c(f"platform workspace {DANG} --samples 5000 --seed 3 --orientation 5,0,10 --format json -o {{out}}/ws.json"),
    "platform_error_arm_file": c(f"platform ik {P2} --pose 0,0,0,0,0,0"),
    "platform_error_bad_lengths": c(f"platform fk {DANG} --lengths 1,2,3"),
    "simulate_planar2r_effects_truth": c(f"simulate {P2} --effects coulomb,viscous,spring@2,cogging@1:k=12 --noise 0.05 --seed 1 --duration 5 -o {{out}}/data.csv --truth {{out}}/truth.json"),
    "simulate_panda_no_ddq": c("simulate robots/panda.yaml --effects coulomb@1-3:amp=0.5,gain:g=0.05 --duration 4 --no-ddq -o {out}/panda.csv --truth {out}/panda.json"),
    "simulate_puma560_mdh_quiet": c(sim()),
    "simulate_planar3r_npz": c(f"simulate {P3} --effects offset,stribeck --duration 3 --seed 4 -o {{out}}/p3.npz"),
    "simulate_tx40_motor_side": c("simulate robots/tx40.yaml --side motor --motor-params Fcm6=0.06,Fvm6=6e-4,Iam6=1e-5 --duration 3 --seed 2 -o {out}/tx40_motor.csv --truth {out}/tx40_truth.json"),
    "simulate_planar2r_stdout": c(f"simulate {P2} --duration 1 --seed 5"),
    "simulate_error_truth_stdout": c(f"simulate {P2} --truth -"),
    **{f"simulate_error_{k}": c(f"simulate {MDH} {a}") for k, a in (
        ("unknown_effect", "--effects backlash -o {out}/x.csv"), ("joint_range", "--effects spring@7 -o {out}/x.csv"),
        ("cogging_k", "--effects cogging:k=12.5 -o {out}/x.csv"), ("negative_noise", "--noise -0.1 -o {out}/x.csv"),
        ("no_folder", "-o {out}/nowhere/data.csv"), ("txt", "-o {out}/data.txt"))},
    # identify (numbers of their JSON outputs compared to 1e-12 relative)
    "identify_puma560_mdh_sim_json": c(f"identify {MDH} {{out}}/sim.csv --format json -q", sim()),
    "identify_puma560_mdh_sim_table": c(SAVE, sim()),
    "identify_codegen_model_c": c(f"codegen {MDH} --model {{out}}/model.json --lang c -o {{out}}/puma_id.c", sim(), SAVE),
    "identify_validate_test_json": c(f"identify {MDH} {{out}}/r1.csv --validate {{out}}/r2.csv --test {{out}}/r3.csv --format json -q",
                                     *(sim(f"r{k}.csv", k, 4) for k in (1, 2, 3))),
    "identify_declared_friction_no_diagnose_json": c(f"identify {MDH} {{out}}/sim.csv --friction coulomb,viscous --no-diagnose --format json -q", sim()),
    "identify_error_missing_data": c(f"identify {MDH} {{out}}/none.csv"),
    # only with ROOT/../shared/data/staubli-tx40 (examples/tx40.recording.yaml's paths are relative to itself)
    "identify_tx40_recording_json": c("identify robots/tx40.yaml examples/tx40.recording.yaml --side motor --cutoff 20 --format json -q"),
}
NEEDS_SHARED = {"identify_tx40_recording_json"}


def run(py, args, scratch, root, env):
    """(exit code, stdout, stderr) of one minparam_cli run; a timeout is exit 124 with a note on stderr."""
    try:
        r = subprocess.run([py, "-m", "minparam_cli", *[a.format(out=scratch) for a in args]], cwd=root, env=env,
                           capture_output=True, timeout=600)
        return r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired as e:
        return 124, e.stdout or b"", (e.stderr or b"") + b"\nsame_outputs: timed out after 600 s\n"


def capture(outdir: Path, py: str, src, root: Path, only: str = "") -> int:
    outdir.mkdir(parents=True, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"COLUMNS": "200", "MPLBACKEND": "Agg"}
    env |= {"PYTHONPATH": str(Path(src).resolve())} if src else {}
    meta, t_all, bad = {"python": py, "src": src, "root": str(root), "cases": {}}, time.perf_counter(), 0
    for name, (cmd, setup) in CASES.items():
        if only not in name:
            continue
        if name in NEEDS_SHARED and not (root / ".." / "shared" / "data" / "staubli-tx40").is_dir():
            print(f"skipped {name}: no {root.parent / 'shared' / 'data' / 'staubli-tx40'}")
            continue
        scratch, t0, d = Path(tempfile.mkdtemp(prefix="same_outputs_")), time.perf_counter(), outdir / name
        subs = [(str(p).encode(), t) for p, t in ((scratch.resolve(), b"<OUT>"), (scratch, b"<OUT>"),
                                                  (root.resolve(), b"<ROOT>"), (root, b"<ROOT>"))]
        clean = functools.partial(functools.reduce, lambda data, sub: data.replace(*sub), subs)
        try:
            for s in setup:
                if (rc := run(py, s, scratch, root, env))[0]:
                    bad += 1
                    print(f"{name}: setup {' '.join(s)} exit {rc[0]}: {rc[2].decode()[-300:]}", file=sys.stderr)
            rc, out, err = run(py, cmd, scratch, root, env)
            err = clean(err)
            shutil.rmtree(d, ignore_errors=True)
            (d / "files").mkdir(parents=True)
            for fname, data in (("cmd.txt", shlex.join(["minparam", *cmd]).encode() + b"\n"), ("stdout.txt", clean(out)),
                                ("stderr.txt", err), ("stderr_last.txt", err.rstrip(b"\n").split(b"\n")[-1] + b"\n"),
                                ("exit_code.txt", f"{rc}\n".encode())):
                (d / fname).write_bytes(data)
            for f in sorted(p for p in scratch.rglob("*") if p.is_file()):
                (dst := d / "files" / f.relative_to(scratch)).parent.mkdir(parents=True, exist_ok=True)
                dst.write_bytes(f.read_bytes() if f.suffix in (".npz", ".png") else clean(f.read_bytes()))
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
        meta["cases"][name] = round(time.perf_counter() - t0, 3)
        print(f"{meta['cases'][name]:7.2f} s  exit {rc}  {name}", flush=True)
    meta["total_s"] = round(time.perf_counter() - t_all, 3)
    (outdir / "_capture.json").write_text(json.dumps(meta, indent=1) + "\n")
    print(f"{len(meta['cases'])} cases in {meta['total_s']:.1f} s -> {outdir}")
    return 1 if bad else 0


def mask_text(text: str) -> str:
    """Timing fragments and the version string masked; the `time s` column of a batch table blanked."""
    text = VERSION.sub("minparam <version>", text)
    text = SCHEMA.sub("", text)
    text = re.sub(rf'("(?:{"|".join(TIMING_KEYS)})": )-?\d+(\.\d+)?([eE][-+]?\d+)?', r"\1<T>", text)
    lines, span = text.split("\n"), None
    for i, line in enumerate(lines):
        for rx, rep in TIMING_LINES:
            line = rx.sub(rep, line)
        if "  time s  " in line and i + 1 < len(lines) and set(lines[i + 1]) <= {"-", " "}:
            a = line.index("time s")
            m = [mm for mm in re.finditer(r"-+", lines[i + 1]) if mm.start() <= a < mm.end() + 2]
            span = (m[0].start(), m[0].end()) if m else None
        elif span and line.strip() and not set(line) <= {"-", " "}:
            line = line[:span[0]] + " " * (span[1] - span[0]) + line[span[1]:]
        elif not line.strip():
            span = None
        lines[i] = line
    return "\n".join(lines)


def json_diffs(a, b, path="$", out=None):
    """Differences of two parsed JSON values, timing keys dropped: numbers to 1e-12 relative (floor 1e-300), rest exact."""
    out = [] if out is None else out
    a, b = ({k: v for k, v in x.items() if k not in TIMING_KEYS + ADDED_KEYS} if isinstance(x, dict) else x for x in (a, b))
    if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b)):
        if not (a == b or abs(a - b) <= max(1e-12 * max(abs(a), abs(b)), 1e-300)):
            out.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            out.append(f"{path}: keys {sorted(set(a) ^ set(b)) or 'in another order'}")
        for k in a:
            if k in b:
                json_diffs(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b, strict=False)):
            json_diffs(x, y, f"{path}[{i}]", out)
    elif type(a) is not type(b) or a != b:
        out.append(f"{path}: {a!r} != {b!r}")
    return out


def file_diffs(case: str, rel: str, pa: Path, pb: Path) -> list:
    if not (pa.is_file() and pb.is_file()):
        return [f"{rel}: only in {'A' if pa.is_file() else 'B'}"]
    ba, bb = pa.read_bytes(), pb.read_bytes()
    try:
        ta, tb = ba.decode(), bb.decode()
    except UnicodeDecodeError:  # binary (.npz, .png): byte for byte
        return [] if ba == bb else [f"{rel}: binary files differ ({len(ba)} and {len(bb)} bytes)"]
    if case.startswith("identify") and ta.lstrip()[:1] in "{[" and ta.strip():
        with contextlib.suppress(ValueError):
            return [f"{rel}: {d}" for d in json_diffs(json.loads(ta), json.loads(tb))][:20]
    ma, mb = mask_text(ta), mask_text(tb)
    diff = [] if ma == mb else list(difflib.unified_diff(ma.splitlines(), mb.splitlines(), f"A/{rel}", f"B/{rel}", n=1, lineterm=""))
    return diff[:40] + ([f"... ({len(diff) - 40} more diff lines)"] if len(diff) > 40 else [])


def compare(a: Path, b: Path) -> int:
    cases = sorted({p.name for d in (a, b) for p in d.iterdir() if p.is_dir() and not p.name.startswith("_")})
    n_diff, width = 0, max(map(len, cases), default=4)
    print(f"{'case':<{width}}  result\n{'-' * width}  ---------")
    for case in cases:
        da, db = a / case, b / case
        if not (da.is_dir() and db.is_dir()):
            diffs = [f"case only in {'A' if da.is_dir() else 'B'}"]
        else:
            rels = sorted({str(p.relative_to(d)) for d in (da, db) for p in d.rglob("*") if p.is_file()})
            diffs = [line for rel in rels for line in file_diffs(case, rel, da / rel, db / rel)]
        n_diff += bool(diffs)
        print(f"{case:<{width}}  {'different' if diffs else 'same'}")
        for line in diffs:
            print("    " + line)
    print(f"\n{len(cases) - n_diff} same, {n_diff} different, of {len(cases)} cases")
    return 1 if n_diff else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    cp = sub.add_parser("capture", help="run every case and save its outputs")
    cp.add_argument("outdir", type=Path)
    cp.add_argument("--python", default=sys.executable, help="interpreter that runs minparam_cli")
    cp.add_argument("--src", help="PYTHONPATH of the runs (the src/ folder of the code under test)")
    cp.add_argument("--root", type=Path, default=ROOT, help="cwd of the runs: the folder holding robots/")
    cp.add_argument("--only", default="", help="run only the cases whose name contains this (e.g. symbolic)")
    cm = sub.add_parser("compare", help="compare two captures")
    cm.add_argument("a", type=Path)
    cm.add_argument("b", type=Path)
    args = ap.parse_args(argv)
    return capture(args.outdir, args.python, args.src, args.root, args.only) if args.cmd == "capture" else compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
