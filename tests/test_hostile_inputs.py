"""A generated corpus of broken and hostile inputs, run through every command (issue 14).

The corpus is built here, in a temporary folder, from every shipped robot and platform file,
from a small simulated data file, and from file-system oddities (FIFOs, devices, folders,
dangling links) and bad option values.  Each case must end with exit code 2, exactly one
line on stderr, no traceback, no file left behind, in under 10 s of CPU time and 500 MB.

Most cases run in this process through typer's CliRunner (fast); the cases that would hang
or eat memory if a guard were missing (alias bombs, FIFOs, devices, huge numbers, deep
nesting, binary data) run as subprocesses under an address-space limit and a timeout, two
at a time, with their CPU time measured by wait4() and their peak resident memory read by the
child itself at exit (/proc/self/status).
"""

from __future__ import annotations

import copy
import os
import random
import resource
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from minparam_cli.cli.app import app

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"
# the bound on a case's CPU seconds (the child's user + system time, or the test process's for an in-process case):
# CPU time, not wall time, so that a loaded machine does not fail the test; a case that hangs without using the
# CPU (a FIFO nobody writes) is killed at HANG_LIMIT_S of wall time and fails on its exit code
TIME_LIMIT_S = 10.0
HANG_LIMIT_S = 120.0
MEMORY_LIMIT_MB = 500
ADDRESS_SPACE_LIMIT = 1536 * 2**20  # the subprocesses' hard limit: a missing guard fails fast, never swaps


@dataclass
class Case:
    """One broken input: the command line (paths inside the case's folder) and how to run it."""

    name: str
    args: list[str]
    heavy: bool = False  # run as a subprocess under limits, measured
    needles: tuple[str, ...] = field(default=())  # text the error line must hold


# --------------------------------------------------------------------------- generators


def robot_yaml_files() -> list[Path]:
    out = []
    for p in sorted(ROBOTS.glob("*.yaml")):
        doc = yaml.safe_load(p.read_text())
        if isinstance(doc, dict) and doc.get("kind", "robot") == "robot":
            out.append(p)
    return out


def platform_files() -> list[Path]:
    out = [p for p in sorted(ROBOTS.glob("*.yaml")) if (yaml.safe_load(p.read_text()) or {}).get("kind") == "platform"]
    return out + sorted((ROBOTS / "platforms").glob("*.yaml"))


def bomb(levels: int = 9, width: int = 9, indent: str = "  ") -> str:
    """A "billion laughs" YAML sequence: level k is ``width`` aliases of level k-1."""
    lines = [f"{indent}- &l0 [{', '.join(['lol'] * width)}]"]
    for k in range(1, levels):
        lines.append(f"{indent}- &l{k} [{', '.join([f'*l{k - 1}'] * width)}]")
    lines.append(f"{indent}- [{', '.join([f'*l{levels - 1}'] * width)}]")
    return "\n".join(lines)


def dump(doc: dict) -> str:
    return yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)


def _first_joint(doc: dict) -> dict:
    return doc["joints"][0]


def robot_mutations(doc: dict) -> list[tuple[str, str, bool]]:
    """(label, YAML text, heavy) of every broken variant of one robot document."""
    out = []

    def set_joint(key, value, label, heavy=False, joint=0):
        d = copy.deepcopy(doc)
        d["joints"][joint][key] = value
        out.append((label, dump(d), heavy))

    rest = dump({k: v for k, v in doc.items() if k not in ("name", "gravity")})
    out.append(("alias bomb in name", "name:\n" + bomb() + "\n" + rest, True))
    out.append(("alias bomb in gravity", "gravity:\n" + bomb() + "\n" + rest, True))
    out.append(("recursive alias", "name: &n [*n]\n" + rest, False))
    out.append(("nesting 100000 deep", "name: " + "[" * 100_000 + "]" * 100_000 + "\n" + rest, True))
    text = dump(doc)
    d = copy.deepcopy(doc)
    d["joints"][0]["d"] = "PLACEHOLDER"
    out.append(("5000-digit number", dump(d).replace("PLACEHOLDER", "1" + "0" * 5000), True))
    set_joint("a", 1e308, "a: 1e308", heavy=True)
    set_joint("d", int("9" * 400), "400-digit integer", heavy=True)
    set_joint("theta", "pi/0", "theta: pi/0")
    set_joint("theta", "1" * 80 + "*pi", "long pi expression")
    set_joint("a", float("nan"), "a: .nan")
    set_joint("d", float("-inf"), "d: -.inf")
    set_joint("alpha", [1, 2], "alpha: a list")
    set_joint("a", {"symbol": "a 1", "value": 1}, "bad symbol")
    set_joint("type", "spherical", "unknown joint type")
    set_joint("limits", [1, float("nan")], "NaN limit")
    set_joint("limits", [2, 1], "limits reversed")
    set_joint("name", {"x": 1}, "joint name a mapping")
    d = copy.deepcopy(doc)
    d["name"] = ["a", ["b"]]
    out.append(("name a list", dump(d), False))
    d = copy.deepcopy(doc)
    d["convention"] = ["dh"]
    out.append(("convention a list", dump(d), False))
    d = copy.deepcopy(doc)
    d["gravity"] = [0, float("nan"), -9.81]
    out.append(("NaN gravity", dump(d), False))
    d = copy.deepcopy(doc)
    d["gravity"] = [0, 0, -1e300]
    out.append(("gravity 1e300", dump(d), False))
    d = copy.deepcopy(doc)
    d["joints"] = 3
    out.append(("joints a number", dump(d), False))
    d = copy.deepcopy(doc)
    d["joints"] = [_first_joint(doc)] * 200
    out.append(("200 joints", dump(d), False))
    d = copy.deepcopy(doc)
    d["colour"] = "red"
    out.append(("unknown key", dump(d), False))
    d = copy.deepcopy(doc)
    del d["convention"]
    out.append(("no convention", dump(d), False))
    out.append(("truncated", text[: len(text) // 2] + "\n  - {type: [", False))
    out.append(("python tag", "convention: !!python/object/apply:os.system ['true']\n" + rest, False))
    out.append(("tab-indented", text.replace("\n  ", "\n\t"), False))
    return out


def inertial_mutations(doc: dict) -> list[tuple[str, str]]:
    """Impossible bodies (for simulate, which uses them): only for robots that give inertials."""
    k = next((i for i, j in enumerate(doc["joints"]) if "inertial" in j), None)
    if k is None:
        return []
    out = []
    for label, change in (
        ("mass 1e308", {"mass": 1e308}),
        ("negative mass", {"mass": -1.0}),
        ("zero mass with inertia", {"mass": 0.0}),
        ("triangle inequality", {"inertia": [0.01, 0, 0, 0.01, 0, 1.0]}),
        ("not positive definite", {"inertia": [1.0, 2.0, 0, 1.0, 0, 1.0]}),
        ("negative moment", {"inertia": [-1.0, 0, 0, 1.0, 0, 1.0]}),
        ("NaN inertia", {"inertia": [float("nan"), 0, 0, 1.0, 0, 1.0]}),
        ("huge com", {"com": [1e300, 0, 0]}),
    ):
        d = copy.deepcopy(doc)
        d["joints"][k]["inertial"] = {**d["joints"][k]["inertial"], **change}
        out.append((label, dump(d)))
    return out


URDF_LINK = '<link name="{n}"><inertial><mass value="{m}"/><inertia ixx="{i[0]}" ixy="{i[1]}" ixz="{i[2]}" iyy="{i[3]}" iyz="{i[4]}" izz="{i[5]}"/></inertial></link>\n'
URDF_JOINT = '<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n'


def small_urdf(mass="1", inertia=("0.1", "0", "0", "0.1", "0", "0.1"), axis="0 0 1", name="r") -> str:
    return (f'<?xml version="1.0"?>\n<robot name="{name}">\n' + URDF_LINK.format(n="base", m="1", i=("1", "0", "0", "1", "0", "1"))
            + URDF_LINK.format(n="l1", m=mass, i=inertia) + URDF_JOINT.format(n="j1", p="base", c="l1", axis=axis) + "</robot>\n")


def urdf_mutations(text: str) -> list[tuple[str, str, bool]]:
    """Broken variants of a URDF text (a shipped one, or ``small_urdf()``)."""
    first_mass = text.index('<mass value="') + len('<mass value="')
    end = text.index('"', first_mass)

    def with_mass(v):
        return text[:first_mass] + v + text[end:]

    ent = ('<?xml version="1.0"?>\n<!DOCTYPE r [\n <!ENTITY a "aaaaaaaaaa">\n'
           + "".join(f' <!ENTITY a{i} "{("&a" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n' for i in range(1, 10))
           + ']>\n<robot name="&a9;"></robot>\n')
    return [
        ("entity bomb", ent, True),
        ("external entity", '<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<robot name="&x;"/>\n', False),
        ("mass 1e400", with_mass("1e400"), False),
        ("mass 1e308", with_mass("1e308"), True),
        ("mass NaN", with_mass("nan"), False),
        ("mass -1", with_mass("-1"), False),
        ("mass 5000 digits", with_mass("1" + "0" * 5000), True),
        ("mass text", with_mass("heavy"), False),
        ("nested 100000 deep", text.replace("</robot>", "<a>" * 100_000 + "</a>" * 100_000 + "</robot>"), True),
        ("truncated", text[: len(text) // 2], False),
        ("not a robot", '<?xml version="1.0"?>\n<html><body/></html>\n', False),
        ("no name", text.replace('<robot name="', '<robot nom="', 1), False),
    ]


def platform_mutations(doc: dict) -> list[tuple[str, str, bool]]:
    out = []
    rest = dump({k: v for k, v in doc.items() if k != "name"})
    out.append(("alias bomb in name", "name:\n" + bomb() + "\n" + rest, True))
    d = copy.deepcopy(doc)
    d["leg_limits"] = [1, "PLACEHOLDER"]
    out.append(("5000-digit number", dump(d).replace("PLACEHOLDER", "1" + "0" * 5000), True))
    side = "base" if "base" in doc else "nodes"

    def changed(label, fn, heavy=False):
        d = copy.deepcopy(doc)
        fn(d)
        out.append((label, dump(d), heavy))

    if side == "base":
        if "radius" in doc["base"]:
            changed("radius NaN", lambda d: d["base"].__setitem__("radius", float("nan")))
            changed("radius 1e308", lambda d: d["base"].__setitem__("radius", 1e308), True)
            changed("radius 400 digits", lambda d: d["base"].__setitem__("radius", int("9" * 400)), True)
            changed("angle pi/0", lambda d: d["base"].__setitem__("angles", ["pi/0"] + list(d["base"]["angles"][1:])))
            changed("collinear base", lambda d: d["base"].__setitem__("angles", [0] * len(d["base"]["angles"])))
            changed("angles a number", lambda d: d["base"].__setitem__("angles", 3))
        else:
            changed("collinear base nodes", lambda d: d["base"].__setitem__("nodes", {k: [float(i), 0.0, 0.0] for i, k in enumerate(d["base"]["nodes"])}))
            changed("NaN node", lambda d: d["base"]["nodes"].__setitem__(next(iter(d["base"]["nodes"])), [float("nan"), 0, 0]))
    else:
        changed("NaN node", lambda d: d["nodes"].__setitem__(next(iter(d["nodes"])), [float("nan"), 0, 0]))
        changed("node 1e308", lambda d: d["nodes"].__setitem__(next(iter(d["nodes"])), [1e308, 0, 0]), True)
    changed("leg limits NaN", lambda d: d.__setitem__("leg_limits", [float("nan"), 300]))
    changed("leg limits reversed", lambda d: d.__setitem__("leg_limits", [300, 100]))
    changed("legs missing", lambda d: d.pop("legs"))
    changed("leg a mapping of lists", lambda d: d["legs"].__setitem__(0, {"nodes": [["B1"], "P2"]}))
    changed("unknown key", lambda d: d.__setitem__("colour", "red"))
    changed("units unknown", lambda d: d.__setitem__("units", {"length": "furlong"}))
    return out


def data_mutations(csv_text: str) -> list[tuple[str, bytes, str, bool]]:
    """(label, bytes, suffix, heavy) of broken data files made from a good CSV."""
    header, *rows = csv_text.splitlines()
    rng = random.Random(7)
    random_bytes = bytes(rng.getrandbits(8) for _ in range(300_000))
    buf = __import__("io").BytesIO()
    np.save(buf, np.zeros((10, 3)))
    return [
        ("random bytes .csv", random_bytes, ".csv", True),
        ("random bytes .npz", random_bytes, ".npz", True),
        ("a .npy named .npz", buf.getvalue(), ".npz", False),
        ("zip that is not npz", b"PK\x03\x04" + random_bytes[:2000], ".npz", False),
        ("empty", b"", ".csv", False),
        ("header only", (header + "\n").encode(), ".csv", False),
        ("no time column", ("x" + header[1:] + "\n" + "\n".join(rows[:50]) + "\n").encode(), ".csv", False),
        ("text in a number", (header + "\n" + "\n".join(rows[:50]) + "\n" + rows[50].replace(",", ",abc,", 1) + "\n").encode(), ".csv", False),
        ("a row too short", (header + "\n" + "\n".join(rows[:50]) + "\n1,2\n").encode(), ".csv", False),
        ("header of 2 MiB", b"t," + b"q" * (2 * 2**20) + b"\n1,2\n", ".csv", True),
        ("all NaN", (header + "\n" + "\n".join(",".join(["nan"] * len(header.split(","))) for _ in range(50)) + "\n").encode(), ".csv", False),
        ("latin-1 header", (header.replace("t", "\xe9", 1) + "\n").encode("latin-1") + "\n".join(rows[:20]).encode(), ".csv", False),
        # joints numbered from 0 are read (--columns accepts 0- or 1-based numbering); a gap is refused
        ("joints q0, q2", (header.replace("q1", "q0") + "\n" + "\n".join(rows[:50]) + "\n").encode(), ".csv", False),
    ]


# --------------------------------------------------------------------------- the corpus


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> tuple[Path, list[Case]]:
    base = tmp_path_factory.mktemp("corpus")
    inp = base / "in"
    inp.mkdir()
    cases: list[Case] = []
    n = 0

    def put(text: str | bytes, suffix: str) -> str:
        nonlocal n
        n += 1
        p = inp / f"f{n:04d}{suffix}"
        p.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
        return str(p)

    # a good data file for the robot-side cases of identify
    good_csv = inp / "good.csv"
    r = CliRunner().invoke(app, ["simulate", str(ROBOTS / "planar2r.yaml"), "--duration", "3", "--rate", "100", "-o", str(good_csv), "-q"])
    assert r.exit_code == 0, r.output
    commands = [
        lambda f: ["derive", f],
        lambda f: ["check", f],
        lambda f: ["simulate", f, "--duration", "1", "-o", "{out}/sim.csv"],
        lambda f: ["identify", f, str(good_csv), "-o", "{out}/report.txt"],
        lambda f: ["singular", f, "--scan", "--step", "90"],
        lambda f: ["derive", f, "--method", "projection", "--gravity", "0,0,-9.81", "-o", "{out}/d.json"],
    ]

    # 1. every shipped robot YAML, every mutation, commands in turn
    for robot in robot_yaml_files():
        doc = yaml.safe_load(robot.read_text())
        for i, (label, text, heavy) in enumerate(robot_mutations(doc)):
            cmd = commands[i % len(commands)]
            cases.append(Case(f"{robot.name}: {label}", cmd(put(text, ".yaml")), heavy))
        for label, text in inertial_mutations(doc):
            f = put(text, ".yaml")
            cases.append(Case(f"{robot.name}: {label} (simulate)", ["simulate", f, "--duration", "1", "-o", "{out}/sim.csv"]))
            cases.append(Case(f"{robot.name}: {label} (check)", ["check", f]))
    # 2. URDF: the shipped ones and a small one
    for name, text in [(p.name, p.read_text()) for p in sorted(ROBOTS.glob("*.urdf"))] + [("small.urdf", small_urdf())]:
        for i, (label, bad, heavy) in enumerate(urdf_mutations(text)):
            cases.append(Case(f"{name}: {label}", commands[i % len(commands)](put(bad, ".urdf")), heavy))
    for label, kw in (("axis zero", {"axis": "0 0 0"}), ("axis 1e-300", {"axis": "0 0 1e-300"}), ("axis NaN", {"axis": "nan 0 1"}),
                      ("inertia triangle", {"inertia": ("0", "0", "0", "0", "0", "1")}), ("name empty", {"name": ""})):
        f = put(small_urdf(**kw), ".urdf")
        cases.append(Case(f"small.urdf: {label} (simulate)", ["simulate", f, "--duration", "1", "-o", "{out}/sim.csv"]))
    # 3. platform files
    for pf in platform_files():
        doc = yaml.safe_load(pf.read_text())
        sub = (["fk", "{f}", "--lengths", ",".join(["200"] * len(doc["legs"]))] if "nodes" in doc
               else ["ik", "{f}", "--pose", "0,0,200,0,0,0"])
        for label, text, heavy in platform_mutations(doc):
            f = put(text, ".yaml")
            cases.append(Case(f"{pf.name}: {label}", ["platform"] + [f if a == "{f}" else a for a in sub], heavy))
    # 4. data files
    csv_text = good_csv.read_text()
    for label, data, suffix, heavy in data_mutations(csv_text):
        f = put(data, suffix)
        cases.append(Case(f"data: {label}", ["identify", str(ROBOTS / "planar2r.yaml"), f, "-o", "{out}/r.json"], heavy))
    # 5. file-system oddities, as the robot file and as the data file
    fifo = inp / "pipe.yaml"
    os.mkfifo(fifo)
    fifo_csv = inp / "pipe.csv"
    os.mkfifo(fifo_csv)
    fifo_urdf = inp / "pipe.urdf"
    os.mkfifo(fifo_urdf)
    dangling = inp / "gone.yaml"
    dangling.symlink_to(inp / "nowhere.yaml")
    loop = inp / "loop.yaml"
    loop.symlink_to(loop)
    folder = inp / "folder.yaml"
    folder.mkdir()
    planar = str(ROBOTS / "planar2r.yaml")
    odd_robots = [str(fifo), str(fifo_urdf), str(dangling), str(loop), "/dev/zero", "/dev/urandom", "/dev/null"]
    for f in odd_robots:
        for args in (["derive", f], ["check", f], ["simulate", f, "-o", "{out}/s.csv"], ["identify", f, str(good_csv)],
                     ["singular", f, "--scan"], ["platform", "ik", f, "--pose", "0,0,200,0,0,0"]):
            cases.append(Case(f"odd robot {f if f.startswith('/dev') else Path(f).name}: {args[0]}", args, heavy=True))
    cases.append(Case("robot is a folder (identify)", ["identify", str(folder), str(good_csv)]))
    for f in [str(fifo_csv), "/dev/zero", "/dev/urandom", str(folder), str(dangling)]:
        cases.append(Case(f"odd data {f if f.startswith('/dev') else Path(f).name}", ["identify", planar, f], heavy=True))
        cases.append(Case(f"odd --test {Path(f).name}", ["identify", planar, str(good_csv), "--test", f], heavy=True))
    # 6. bad option values
    dodeka = str(ROBOTS / "dodekapod_dang2013.yaml")
    bad_options = [
        ["derive", planar, "--seed", "-1"], ["derive", planar, "--seed", "1.5"], ["derive", planar, "--seed", "x"],
        ["derive", planar, "--gravity", "nan,0,0"], ["derive", planar, "--gravity", "0,0,inf"], ["derive", planar, "--gravity", "0,0"],
        ["derive", planar, "--samples", "0"], ["derive", planar, "--jobs", "0"], ["derive", planar, "--snap-angles", "nan"],
        ["derive", planar, "--method", "magic"], ["derive", planar, "--bogus"], ["derive", planar, "-o", "{out}"],
        ["derive", planar, "-o", "."], ["derive", planar, "-o", "{out}/no/such/dir/x.json"],
        ["identify", planar, str(good_csv), "--seed", "-3"], ["identify", planar, str(good_csv), "--cutoff", "nan"],
        ["identify", planar, str(good_csv), "--rate", "inf"], ["identify", planar, str(good_csv), "--split", "nan,0.2,0.2"],
        ["identify", planar, str(good_csv), "--still-speed", "-inf"], ["identify", planar, str(good_csv), "--prior-weight", "nan"],
        ["identify", planar, str(good_csv), "--gravity", "1e999,0,0"], ["identify", planar, str(good_csv), "--min-gain", "nan"],
        ["identify", planar, str(good_csv), "-o", "{out}"],
        ["simulate", planar, "--seed", "-1"], ["simulate", planar, "--strength", "nan"], ["simulate", planar, "--noise", "inf"],
        ["simulate", planar, "--duration", "nan"], ["simulate", planar, "--rate", "-inf"], ["simulate", planar, "--base-frequency", "nan"],
        ["simulate", planar, "-o", "{out}/d.csv", "--truth", "{out}"], ["simulate", planar, "-o", "{out}", "--truth", "{out}/t.json"],
        ["simulate", planar, "-o", "."],
        ["singular", planar, "--q", "0,nan"], ["singular", planar, "--q", "0,0", "--seed", "-1"], ["singular", planar, "--q", "0,0", "--epsilon", "nan"],
        ["singular", planar, "--q", "0,0", "--damping", "inf"], ["singular", planar, "--twist", "nan,0,0,0,0,0", "--q", "0,0"],
        ["platform", "ik", dodeka, "--pose", "0,0,nan,0,0,0"], ["platform", "ik", dodeka, "--position", "0,0,200", "--normal", "nan,0,1"],
        ["platform", "ik", dodeka, "--position", "0,0,200", "--normal", "0,0,0"], ["platform", "ik", dodeka, "--pose", "0,0,200,0,0,0", "--yaw", "inf"],
        ["platform", "fk", dodeka, "--lengths", "200,200,200,200,200,nan"], ["platform", "fk", dodeka, "--lengths", "200,200,200,200,200,inf"],
        ["platform", "fk", dodeka, "--lengths", "200,200,200,200,200,200", "--seed", "-1"],
    ]
    for args in bad_options:
        cases.append(Case("option: " + " ".join(a.replace(str(ROBOTS) + "/", "") for a in args[:1] + args[2:]), args))
    return base, cases


# --------------------------------------------------------------------------- running


def _fill(args: list[str], out: Path) -> list[str]:
    return [a.replace("{out}", str(out)) for a in args]


def _check_result(case: Case, code: int, stderr: str, out: Path, elapsed: float) -> list[str]:
    """What is wrong with one case's run (empty: handled as promised)."""
    problems = []
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if code != 2:
        problems.append(f"exit {code}")
    if len(lines) != 1:
        problems.append(f"{len(lines)} stderr lines")
    if "Traceback" in stderr or "internal error" in stderr:
        problems.append("traceback/internal error")
    left = sorted(p.name for p in out.rglob("*")) if out.exists() else []
    if left:
        problems.append(f"left {left}")
    if elapsed > TIME_LIMIT_S:
        problems.append(f"{elapsed:.1f} s")
    for needle in case.needles:
        if needle not in stderr:
            problems.append(f"no {needle!r}")
    return problems if not problems else problems + [stderr.strip()[:300]]


def _limits():  # the child of a heavy case: bounded address space, no core files
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_LIMIT, ADDRESS_SPACE_LIMIT))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


# The child reports its own peak resident memory: VmHWM of /proc/self/status, read at exit. wait4()'s ru_maxrss
# cannot be used: Linux carries the forking process's high-water mark into the child's across fork and exec,
# so every child would report at least this test process's size (553 MB late in a whole-suite run).
_CHILD = """import atexit, os, runpy, sys
def _peak():
    with open("/proc/self/status") as f:
        kb = next((line.split()[1] for line in f if line.startswith("VmHWM:")), "")
    with open(os.environ["HOSTILE_PEAK_FILE"], "w") as f:
        f.write(kb)
atexit.register(_peak)
sys.argv = ["minparam_cli", *sys.argv[1:]]
runpy.run_module("minparam_cli", run_name="__main__", alter_sys=True)
"""


def _run_heavy(case: Case, out: Path) -> tuple[int, str, float, float]:
    """(exit code, stderr, CPU seconds, peak RSS MB) of one case as ``python -m minparam_cli``."""
    peak_file = out.parent / f"{out.name}.peak"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "HOSTILE_PEAK_FILE": str(peak_file)}
    env.pop("MINPARAM_DEBUG", None)
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, *_fill(case.args, out)], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, preexec_fn=_limits, env=env, cwd=out)
    # stderr is one short line when all goes well: read it after the exit (a pipe holds 64 kB)
    deadline = t0 + HANG_LIMIT_S
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() > deadline:
            proc.kill()
            pid, status, usage = os.wait4(proc.pid, 0)
            break
        time.sleep(0.01)
    elapsed = usage.ru_utime + usage.ru_stime
    proc.returncode = os.waitstatus_to_exitcode(status)
    stderr = proc.stderr.read().decode("utf-8", "replace")
    proc.stderr.close()
    kb = peak_file.read_text().strip() if peak_file.exists() else ""
    rss = int(kb) / 1024 if kb.isdigit() else usage.ru_maxrss / 1024  # killed before its atexit: wait4's figure
    return proc.returncode, stderr, elapsed, rss


def test_the_corpus_is_large_and_covers_every_class(corpus):
    _, cases = corpus
    assert len(cases) >= 300, len(cases)
    print(f"\ncorpus: {len(cases)} cases, {sum(c.heavy for c in cases)} as subprocesses")
    names = " ".join(c.name for c in cases)
    for needle in ("alias bomb", "pipe", "/dev/zero", "urandom", "1e308", "400-digit", "5000", "pi/0", "NaN gravity",
                   "triangle", "collinear", "option: identify", "random bytes", "entity bomb", "nesting"):
        assert needle in names, needle
    assert 30 <= sum(c.heavy for c in cases) <= 150


def test_light_cases_in_process(corpus, tmp_path):
    """Every in-process case: exit 2, one stderr line, no traceback, no file left, < 10 s of CPU, < 500 MB more."""
    _, cases = corpus
    runner = CliRunner()
    failures = []
    slowest = (0.0, "")
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    for k, case in enumerate(c for c in cases if not c.heavy):
        out = tmp_path / f"out{k}"
        out.mkdir()
        t0 = time.process_time()
        r = runner.invoke(app, _fill(case.args, out))
        elapsed = time.process_time() - t0
        slowest = max(slowest, (elapsed, case.name))
        stderr = r.stderr + ("Traceback" if r.exception is not None and not isinstance(r.exception, SystemExit) else "")
        problems = _check_result(case, r.exit_code, stderr, out, elapsed)
        if problems:
            failures.append(f"{case.name} {case.args[:1]}: {problems}")
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 - rss0
    assert not failures, f"{len(failures)} cases failed:\n" + "\n".join(failures)
    assert grown < MEMORY_LIMIT_MB, f"the test process grew by {grown:.0f} MB"
    print(f"\nlight cases: slowest {slowest[0]:.2f} s ({slowest[1]}), peak RSS grew {grown:.0f} MB")


def test_heavy_cases_as_subprocesses(corpus, tmp_path):
    """Bombs, FIFOs, devices, huge numbers, binary data: measured in a child process with RLIMIT_AS."""
    _, cases = corpus
    heavy = [c for c in cases if c.heavy]
    outs = []
    for k in range(len(heavy)):
        (tmp_path / f"out{k}").mkdir()
        outs.append(tmp_path / f"out{k}")
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda kc: _run_heavy(kc[1], outs[kc[0]]), enumerate(heavy)))
    failures = []
    for case, out, (code, stderr, elapsed, rss) in zip(heavy, outs, results, strict=True):
        problems = _check_result(case, code, stderr, out, elapsed)
        if rss > MEMORY_LIMIT_MB:
            problems.append(f"peak RSS {rss:.0f} MB")
        if problems:
            failures.append(f"{case.name} {case.args[:1]}: {problems}")
    assert not failures, f"{len(failures)} of {len(heavy)} cases failed:\n" + "\n".join(failures)
    times = [r[2] for r in results]
    rss = [r[3] for r in results]
    worst = heavy[int(np.argmax(times))].name
    print(f"\nheavy cases: {len(heavy)}, median {np.median(times):.2f} s, slowest {max(times):.2f} s ({worst}), "
          f"peak RSS max {max(rss):.0f} MB")
