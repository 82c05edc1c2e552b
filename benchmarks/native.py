"""The estimator FMU's doStep, and the library's Identifier against the bare C core, in one run;
writes benchmarks/NATIVE.md.

Measured on the same recorded plant samples (the Python plant, 60 s at 0.1 s, default
parameters: paper solver, momentum method), interleaved in ROUNDS rounds, each the best of
REPEATS passes, CPU time per sample:

* estimator FMU ``doStep`` through fmpy (after ``setReal`` of the inputs);
* the core's update alone: ``Identifier.update_flat`` (the library's Python face of the C core)
  and the bare C core through ctypes (``spacerobot.core.estimator.NativeEstimator.update``),
  and their ratio;
* instantiation + 60 s of estimation of the native FMU in a fresh process started from an empty
  environment (wall time, fmpy's ``simulate_fmu``, which extracts the FMU first);
* the closed loop in the C host, spatial, 60 s: the native plant and estimator FMUs wired as the
  SSP wires them (plant outputs -> estimator inputs, estimator ``ident.excite`` and
  ``ident.excite_rate`` -> plant) in ``tests/c_host/fmu_host.c`` (compiled with the system C compiler), 600
  steps of 0.1 s, started from an empty environment: the process's wall time and the stepping
  loop's own time (no Python in the process).

Nothing here asserts a timing. Run: ``python benchmarks/native.py [--quick] [--out PATH]``;
``--dostep-only`` measures the native FMU's ``doStep`` alone (the figure of issue #26) and
prints it without writing NATIVE.md (``--robots spatial`` for one robot).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.run import fmt, machine, record_outputs, started, table  # noqa: E402
from spacerobot.core.estimator import NativeEstimator  # noqa: E402
from spacerobot.estimator import Identifier  # noqa: E402
from spacerobot.estimator.identifier import KEYS  # noqa: E402
from spacerobot.fmi.build import build_fmu  # noqa: E402
from spacerobot.robots import scenario  # noqa: E402

ROUNDS, REPEATS = 5, 5


def flat_samples(outs: list) -> list:
    """The samples in the flat layout both cores take (``Identifier.update_flat``)."""
    return [np.concatenate([np.ravel(o[k]) for k in KEYS]).astype(float) for o in outs]


def input_rows(outs: list, names: list) -> list:
    """The estimator FMU's input values (in ``names`` order) of each sample."""
    keys = {"base.r": "r_S", "base.v": "v_S", "base.A": "A", "base.omega": "omega_B",
            "base.a": "a_S", "base.alpha": "alpha_B", "arm.q": "q", "arm.qd": "qd",
            "arm.qdd": "qdd", "thrust.F": "F", "thrust.M": "M", "thrust.J": "J", "thrust.H": "H"}

    def value(o, name):
        stem, idx = name.split("[")
        idx = [int(i) - 1 for i in idx.rstrip("]").split(",")]
        x = o[keys[stem]]
        return float(x[idx[0], idx[1]] if len(idx) == 2 else x[idx[0]])
    return [[value(o, n) for n in names] for o in outs]


def dostep_cost(fmu: Path, rows: list, repeats: int) -> float:
    """Best CPU time per ``doStep`` [us] over ``repeats`` passes over ``rows``."""
    best = float("inf")
    for _ in range(repeats):
        est = started(fmu, "estimator")
        vr = est.vrs(est.names("input"))
        acc, t = 0.0, 0.0
        for r in rows:
            est.fmu.setReal(vr, r)
            c = time.process_time()
            est.fmu.doStep(t, 0.1)
            acc += time.process_time() - c
            t += 0.1
        est.free()
        best = min(best, acc / len(rows) * 1e6)
    return best


def core_cost(make, flats: list, repeats: int) -> float:
    """Best CPU time per update [us] of ``make()``'s ``update_flat``/``update``."""
    best = float("inf")
    for _ in range(repeats):
        core = make()
        update = getattr(core, "update_flat", None) or core.update
        c = time.process_time()
        for k, x in enumerate(flats):
            update(0.1 * k, x)
        best = min(best, (time.process_time() - c) / len(flats) * 1e6)
    return best


def cold_run(fmu: Path, seconds: float) -> float:
    """Wall time [s] in a fresh Python process, empty environment, from after ``import fmpy``
    to the end of fmpy's ``simulate_fmu`` (extract, instantiate, ``seconds`` of estimation),
    measured by that process itself."""
    code = ("import time, fmpy, sys; t0 = time.perf_counter(); "
            "r = fmpy.simulate_fmu(sys.argv[1], stop_time=float(sys.argv[2]), "
            "output_interval=0.1); assert len(r) > 1; print(time.perf_counter() - t0)")
    r = subprocess.run([sys.executable, "-c", code, str(fmu), str(seconds)], check=True,
                       env={"PATH": "/usr/bin:/bin"}, capture_output=True, text=True)
    return float(r.stdout.strip().splitlines()[-1])


def _c_host(tmp: Path):
    """``tests/c_host/fmu_host.c`` compiled with the system C compiler, or None."""
    import shutil
    cc = next((shutil.which(c) for c in (os.environ.get("CC", ""), "cc", "gcc", "clang")
               if c and shutil.which(c)), None)
    if cc is None:
        return None
    host = tmp / "fmu_host"
    if not host.exists():
        subprocess.run([cc, "-std=c99", "-O2", "-o", str(host),
                        str(ROOT / "tests" / "c_host" / "fmu_host.c"), "-ldl", "-lm"], check=True)
    return host


def _extracted(kind: str, sc, folder: Path) -> dict:
    """The native FMU of ``kind`` built and extracted into ``folder``: its linux64 binary,
    resource URI, GUID, value references by name, Real output value references."""
    import zipfile
    path = build_fmu(kind, sc, folder)
    d = folder / "x"
    with zipfile.ZipFile(path) as z:
        z.extractall(d)
    table_ = (d / "resources" / "spacerobot_variables.txt").read_text().splitlines()
    ident = next(line.split()[1] for line in table_ if line.startswith("model "))
    return {"so": d / "binaries" / "linux64" / f"{ident}.so", "uri": (d / "resources").as_uri(),
            "guid": next(line.split()[1] for line in table_ if line.startswith("guid ")),
            "vr": {f[6]: f[0] for f in map(str.split, table_) if f and f[0].isdigit()},
            "out": [f[0] for f in map(str.split, table_)
                    if f and f[0].isdigit() and f[1] == "Real" and f[2] == "output"]}


def _host_loop_time(args) -> tuple:
    """(process wall time, the host's own stepping-loop time) [s] of one host run."""
    t0 = time.perf_counter()
    r = subprocess.run(args, capture_output=True, text=True, env={"PATH": "/usr/bin:/bin"},
                       check=True)
    return time.perf_counter() - t0, float(r.stderr.strip().splitlines()[-1].split()[-2])


def c_host_closed_loop(tmp: Path, robot: str = "spatial", seconds: float = 60.0,
                       runs: int = 5):
    """Wall time [s] of the closed loop in the C host (``tests/c_host/fmu_host.c``), per run:
    ``(process wall times, stepping-loop times)``, or None where no C compiler is found."""
    from spacerobot.system.ssd import ESTIMATOR, PLANT, system_connections

    host = _c_host(tmp)
    if host is None:
        return None
    sc = scenario(robot)
    p, e = (_extracted(kind, sc, tmp / f"loop_{kind}") for kind in (PLANT, ESTIMATOR))
    conns = system_connections(robot)
    fwd = [f"{p['vr'][a]}:{e['vr'][b]}" for s, a, t, b in conns if (s, t) == (PLANT, ESTIMATOR)]
    back = [f"{e['vr'][a]}:{p['vr'][b]}" for s, a, t, b in conns if (s, t) == (ESTIMATOR, PLANT)]
    args = [str(host), "-e", str(e["so"]), "-g", e["guid"], "-r", e["uri"], "-w", ",".join(fwd),
            "-b", ",".join(back), "-o", ",".join(e["out"]), str(p["so"]), p["guid"], p["uri"],
            "0.1", str(int(round(seconds / 0.1))), p["vr"]["ident.excite"]]
    walls, loops = zip(*(_host_loop_time(args) for _ in range(runs)))
    return list(walls), list(loops)


def c_host_estimator(tmp: Path, robot: str, names: list, rows: list, runs: int = 5):
    """The estimator FMU alone in the C host, fed the recorded samples ``rows`` (its inputs
    ``names``) as the host's input file: per step [us], the host's stepping-loop time over the
    steps (fmi2SetReal of the inputs, fmi2DoStep, fmi2GetReal and printing of one output), per
    run; None without a C compiler."""
    host = _c_host(tmp)
    if host is None:
        return None
    e = _extracted("estimator", scenario(robot), tmp / f"alone_{robot}")
    inputs = tmp / f"inputs_{robot}.csv"
    # the recording LAPS times over (later laps jump back to its start, as a new manoeuvre):
    # one run's loop long enough that the process's one-off costs (first touches of the
    # instance's memory, the output buffer) are not the per-step figure
    steps = rows * LAPS
    inputs.write_text(",".join(e["vr"][n] for n in names) + "\n"
                      + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in steps))
    args = [str(host), "-i", str(inputs), str(e["so"]), e["guid"], e["uri"], "0.1",
            str(len(steps)), e["vr"]["base.m"]]
    return [_host_loop_time(args)[1] / len(steps) * 1e6 for _ in range(runs)]


#: laps of the recording in the C host's estimator-alone run
LAPS = 10


def spread(xs) -> str:
    return f"{fmt(float(np.median(xs)))} ({fmt(min(xs))}-{fmt(max(xs))})"


def dostep_only(robots, rounds: int, repeats: int, seconds: float) -> None:
    """The native FMU's ``doStep`` alone, per robot: min, median and range over ``rounds``
    rounds (each the best of ``repeats`` passes), printed."""
    with tempfile.TemporaryDirectory(prefix="srnative_") as tmp:
        for robot in robots:
            sc = scenario(robot)
            native = build_fmu("estimator", sc, Path(tmp) / robot / "native")
            outs = record_outputs(sc, seconds)
            rows = input_rows(outs, started(native, "names").names("input"))
            xs = [dostep_cost(native, rows, repeats) for _ in range(rounds)]
            print(f"{robot}: native FMU doStep min {min(xs):.2f} us, median "
                  f"{float(np.median(xs)):.2f} us, range {min(xs):.2f}-{max(xs):.2f} us "
                  f"({rounds} rounds x best of {repeats} passes, {len(rows)} samples)",
                  flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    ap.add_argument("--out", default=str(HERE / "NATIVE.md"))
    ap.add_argument("--dostep-only", action="store_true",
                    help="only the native FMU's doStep (printed; NATIVE.md not written)")
    ap.add_argument("--robots", default="planar,spatial",
                    help="with --dostep-only: comma-separated robots (default planar,spatial)")
    a = ap.parse_args(argv)
    rounds, repeats, seconds = (2, 1, 10.0) if a.quick else (ROUNDS, REPEATS, 60.0)
    if a.dostep_only:
        dostep_only([r for r in a.robots.split(",") if r], rounds, repeats, seconds)
        return 0
    info = machine()
    rows_out, cold, host_step = [], {}, {}
    with tempfile.TemporaryDirectory(prefix="srnative_") as tmp:
        res = {}
        for robot in ("planar", "spatial"):
            sc = scenario(robot)
            native = build_fmu("estimator", sc, Path(tmp) / robot / "native")
            outs = record_outputs(sc, seconds)
            names = started(native, "names").names("input")
            rows, flats = input_rows(outs, names), flat_samples(outs)
            r = res[robot] = {k: [] for k in ("fmu_n", "core_n", "core_p")}
            for _ in range(rounds):          # interleaved: the host's speed drifts
                r["fmu_n"].append(dostep_cost(native, rows, repeats))
                r["core_n"].append(core_cost(lambda: NativeEstimator(sc.robot, {"guess": sc.guess}),
                                             flats, repeats))
                r["core_p"].append(core_cost(lambda: Identifier(sc.robot, sc.guess), flats,
                                             repeats))
            cold[robot] = [cold_run(native, 60.0) for _ in range(3)]
            host_step[robot] = c_host_estimator(Path(tmp), robot, names, rows)
            print(robot, {k: round(float(np.median(v)), 1) for k, v in r.items()}, flush=True)
            cr = [p / n for p, n in zip(r["core_p"], r["core_n"])]
            rows_out.append((robot, spread(r["fmu_n"]),
                             spread(r["core_n"]), spread(r["core_p"]), spread(cr),
                             spread([c * 1e3 for c in cold[robot]])))
        loop = c_host_closed_loop(Path(tmp), seconds=seconds)
        if loop is not None:
            print("closed loop in the C host", [round(w, 3) for w in loop[0]], flush=True)
    alone_rows = [(robot, "n/a (no C compiler)" if xs is None else spread(xs))
                  for robot, xs in host_step.items()]
    loop_rows = [("closed loop in the C host, spatial, "
                  f"{seconds:g} s", *(("n/a (no C compiler)",) * 2 if loop is None else
                                     (spread([w * 1e3 for w in loop[0]]),
                                      spread([w * 1e3 for w in loop[1]]))))]
    text = ["# The estimator FMU's doStep; the library's Identifier against the bare C core\n",
            f"Generated by `python benchmarks/native.py{' --quick' if a.quick else ''}` on "
            f"{info['cpu']} ({info['cores']} cores, load "
            f"{' '.join(f'{x:.1f}' for x in info['load'])}), "
            f"{time.strftime('%Y-%m-%d')}. Median of {rounds} interleaved rounds, each the best of "
            f"{repeats} passes over {seconds:g} s of recorded plant samples (0.1 s), CPU time per "
            "sample; the range over the rounds in brackets. Default parameters (paper solver, "
            "momentum method). Cold run: a fresh Python process from an empty environment "
            "(`env -i PATH=/usr/bin:/bin`) that extracts, instantiates and runs the native FMU for "
            "60 s with fmpy's `simulate_fmu`, timed by that process from after its `import fmpy`; wall time, "
            "3 runs.\n",
            table(["robot", "native FMU doStep [us]",
                   "C core update [us]", "Identifier.update_flat [us]",
                   "ratio (per round)", "cold: instantiate + 60 s [ms]"], rows_out),
            "\nThe FMU `doStep` includes fmpy's ctypes call; the C core update includes the "
            "ctypes call of `NativeEstimator.update`; `Identifier.update_flat` is the same core "
            "behind the library's Python class (issue #26: no Numba left). Target of issue #26: "
            "native `doStep` "
            "<= 20 us (spatial), cold run under 1 s.\n",
            "\nNo Python at all: the native plant and estimator FMUs in the C host "
            "`tests/c_host/fmu_host.c` (system C compiler, -O2), wired as the SSP wires them "
            "(plant outputs -> estimator inputs, estimator `ident.excite` and "
            "`ident.excite_rate` -> plant), steps of 0.1 s, started from an empty environment; median (range) "
            "of 5 runs. The process time includes loading and instantiating both FMUs; the "
            "stepping time is the host's own measurement of its loop.\n",
            table(["run", "process wall time [ms]", "stepping [ms]"], loop_rows),
            f"\nThe estimator FMU alone in the same C host, fed the recorded samples above "
            f"({LAPS} laps of them in one run) from the host's input file: the host's stepping-loop "
            "time per step (fmi2SetReal of the "
            "inputs, fmi2DoStep, fmi2GetReal and printing of one output: what a native importer "
            "pays per communication step, without fmpy's Python per call), median (range) of 5 "
            "runs.\n",
            table(["robot", "estimator step in the C host [us]"], alone_rows)]
    Path(a.out).write_text("\n".join(text))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
