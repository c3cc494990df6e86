"""Benchmark of `minparam codegen` (issue 19 targets in brackets).

* generation of the Panda's C code, in process and as a whole `minparam codegen` process [<= 2 s];
* one evaluation of the Panda's base regressor Y_b (7 x 43) [<= 2 us]:
  - the generated C, -O2, timed in a C loop over 1000 random states (no Python in the loop);
  - the generated C called through ctypes, one state per call (the Python call overhead included);
  - pinocchio's computeJointTorqueRegressor (the full 7 x 70 regressor) from Python, one state per call;
  - minparam's own compiled kernel (dynamics/_rnea.c, full regressor): one state per call and
    1000 states per call;
  - the generated NumPy code, 1000 states per call;
* operation counts (multiplications, additions) of the generated programs, Panda and PUMA 560.

Run: python benchmarks/bench_codegen.py   (pinocchio: pip install ".[bench]"; a C compiler `cc`)
"""

from __future__ import annotations

import ctypes
import importlib.util
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from common import ROOT, best_of, minparam_cmd, run_process
from tabulate import tabulate

sys.path.insert(0, str(ROOT / "src"))

from minparam_cli.base.qr import derive_qr  # noqa: E402
from minparam_cli.codegen.functions import Meta, generate_code  # noqa: E402
from minparam_cli.dynamics.regressor import regressor  # noqa: E402
from minparam_cli.robot import DeriveOptions, load_chain  # noqa: E402

PANDA = ROOT / "robots" / "panda.yaml"
STATES = 1000
SEED = 19  # the random states (numpy default_rng)

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "panda.h"
/* per-evaluation CPU time (this thread's: the machine is shared) of panda_base_regressor over states read from states.bin (q, qd, qdd per state) */
int main(int argc, char **argv)
{
    static double s[%(states)d][3][PANDA_DOF];
    double Y[PANDA_DOF * PANDA_N_BASE], sink = 0.0, best = 1e30;
    FILE *f = fopen(argv[1], "rb");
    if (!f || fread(s, sizeof s, 1, f) != 1) return 1;
    fclose(f);
    for (int rep = 0; rep < 15; rep++) {
        struct timespec a, b;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        for (int r = 0; r < 20; r++)
            for (int i = 0; i < %(states)d; i++) {
                panda_base_regressor(s[i][0], s[i][1], s[i][2], Y);
                sink += Y[(i * 7) %% (PANDA_DOF * PANDA_N_BASE)];
            }
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        double ns = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / (20.0 * %(states)d);
        if (ns < best) best = ns;
    }
    printf("%%.1f %%g\n", best, sink);
    (void)argc;
    return 0;
}
"""


def pinocchio_model(chain):
    """The chain as a pinocchio model (placements Post_parent·Pre_j, the joint axes, gravity)."""
    import pinocchio as pin

    model = pin.Model()
    parent = 0
    for j in range(chain.n):
        M = chain.pre[j] if chain.parents[j] < 0 else chain.post[chain.parents[j]] @ chain.pre[j]
        joint = pin.JointModelRevoluteUnaligned(chain.axes[j].copy()) if chain.types[j] == "revolute" else \
            pin.JointModelPrismaticUnaligned(chain.axes[j].copy())
        parent = model.addJoint(0 if chain.parents[j] < 0 else chain.parents[j] + 1, joint,
                                pin.SE3(M[:3, :3].copy(), M[:3, 3].copy()), f"j{j}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    model.gravity.linear = chain.gravity.copy()
    return model, model.createData()


def cpu_best(fn, repeats: int = 7) -> float:
    """Smallest CPU time (s) of this thread over ``repeats`` runs of fn(): the machine is shared, and
    CPU time does not count the time other processes hold the core (wall time would)."""
    out = []
    for _ in range(repeats):
        t0 = time.thread_time()
        fn()
        out.append(time.thread_time() - t0)
    return min(out)


def per_call(fn, calls: int) -> float:
    """CPU time per call, best of 7 runs of ``calls`` calls."""
    return cpu_best(lambda: [fn(i) for i in range(calls)]) / calls


def main() -> None:
    cc = shutil.which("cc")
    _, chain = load_chain(PANDA, DeriveOptions())
    base = derive_qr(chain)
    meta = Meta("robots/panda.yaml", "-", "minparam codegen robots/panda.yaml --lang c -o panda.c", "bench")

    t_gen = best_of(lambda: generate_code(chain, base, "c", "panda", meta), 5)
    tracemalloc.start()  # a separate run: tracing slows every allocation down
    generate_code(chain, base, "c", "panda", meta)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    gen = generate_code(chain, base, "c", "panda", meta)
    tmp = Path(tempfile.mkdtemp(prefix="bench_codegen_"))
    cmd = minparam_cmd() + ["codegen", str(PANDA), "--lang", "c", "-o", str(tmp / "cli.c"), "-q"]
    t_proc, rss = run_process(cmd, repeats=3)
    cpu = []
    for _ in range(3):  # CPU time of the whole process (user + system): what a shared machine does not inflate
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT, check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    rows = [["generate_code (Panda, C), in process", f"{t_gen * 1e3:.1f} ms", "", f"{peak / 2**20:.1f} MiB (tracemalloc)"],
            ["minparam codegen robots/panda.yaml --lang c (process)", f"{t_proc * 1e3:.0f} ms", f"{min(cpu) * 1e3:.0f} ms",
             f"{rss:.0f} MB RSS; target <= 2 s"]]
    print(tabulate(rows, headers=["generation", "wall time", "CPU time", "peak memory, note"], tablefmt="github"))
    print()

    rng = np.random.default_rng(SEED)
    q = rng.uniform(-np.pi, np.pi, (STATES, 7))
    qd, qdd = rng.standard_normal((2, STATES, 7))
    timing = []
    if cc is None:
        print("no C compiler: the generated C is not timed")
    else:
        for suffix, text in gen.files.items():
            (tmp / f"panda{suffix}").write_text(text)
        (tmp / "main.c").write_text(HARNESS % {"states": STATES})
        np.ascontiguousarray(np.stack([q, qd, qdd], axis=1)).tofile(tmp / "states.bin")
        t0 = time.perf_counter()
        subprocess.run([cc, "-O2", "-std=c99", "-o", str(tmp / "bench"), str(tmp / "main.c"), str(tmp / "panda.c"), "-lm"], check=True)
        t_cc = time.perf_counter() - t0
        ns = float(subprocess.run([str(tmp / "bench"), str(tmp / "states.bin")], capture_output=True, text=True, check=True).stdout.split()[0])
        timing.append(["generated C, -O2, C loop", "Y_b 7x43", ns / 1e3])
        subprocess.run([cc, "-O2", "-shared", "-fPIC", "-o", str(tmp / "panda.so"), str(tmp / "panda.c"), "-lm"], check=True)
        lib = ctypes.CDLL(str(tmp / "panda.so"))
        P = ctypes.POINTER(ctypes.c_double)
        args = [[np.ascontiguousarray(x[s]).ctypes.data_as(P) for x in (q, qd, qdd)] for s in range(STATES)]
        out = np.zeros(7 * base.n_base)
        outp = out.ctypes.data_as(P)
        fn = lib.panda_base_regressor
        fn.restype = None
        timing.append(["generated C via ctypes, one state a call", "Y_b 7x43", per_call(lambda i: fn(*args[i], outp), STATES) * 1e6])
        print(f"(compiling the generated C at -O2: {t_cc:.1f} s)")
    try:
        import pinocchio as pin

        model, data = pinocchio_model(chain)
        timing.append(["pinocchio computeJointTorqueRegressor, one state a call", "Y 7x70",
                       per_call(lambda i: pin.computeJointTorqueRegressor(model, data, q[i], qd[i], qdd[i]), STATES) * 1e6])
    except ImportError:
        print("pinocchio not installed: pip install '.[bench]'")
    q1, qd1, qdd1 = q[:, None, :].copy(), qd[:, None, :].copy(), qdd[:, None, :].copy()
    timing.append(["minparam kernel (_rnea.c), one state a call", "Y 7x70",
                   per_call(lambda i: regressor(chain, q1[i], qd1[i], qdd1[i], backend="kernel"), STATES) * 1e6])
    timing.append(["minparam kernel (_rnea.c), 1000 states a call", "Y 7x70",
                   cpu_best(lambda: regressor(chain, q, qd, qdd, backend="kernel")) / STATES * 1e6])
    spec = importlib.util.spec_from_file_location("panda_np", tmp / "panda_np.py")
    (tmp / "panda_np.py").write_text(generate_code(chain, base, "python", "panda", meta).files[".py"])
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    timing.append(["generated NumPy, 1000 states a call", "Y_b 7x43", cpu_best(lambda: mod.base_regressor(q, qd, qdd)) / STATES * 1e6])
    ref = timing[0][2] if cc is not None else None
    print(tabulate([[a, b, f"{t:.3f}", f"{t / ref:.1f}x" if ref else ""] for a, b, t in timing],
                   headers=["Panda, one evaluation", "output", "CPU us / state", "vs generated C"], tablefmt="github"))
    print(f"\nstates: {STATES} random (numpy default_rng seed {SEED}); target for the generated C: <= 2 us\n")

    counts = []
    for robot in ("panda.yaml", "puma560.yaml"):
        _, ch = load_chain(ROOT / "robots" / robot, DeriveOptions())
        b = derive_qr(ch)
        g = generate_code(ch, b, "c", "x", meta, full=True)
        for fn_name, c in g.counts.items():
            counts.append([robot, fn_name, c["mul"], c["add"], c.get("sin", 0) + c.get("cos", 0)])
    print(tabulate(counts, headers=["robot", "function", "multiplications", "additions", "sin + cos"], tablefmt="github"))
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
