"""Benchmarks of the spacerobot co-simulation and estimator (issue #6); writes benchmarks/REPORT.md.

Sections:

1. co-simulation speed: the whole system (plant FMU + estimator FMU through fmpy, 0.1 s
   communication step, :func:`spacerobot.run_ssp`) against a bare RK4 loop over
   Pinocchio's ABA on the same robot at the same 1 ms step; where the time goes;
2. estimator cost per sample: core ``Identifier.update``, the estimator FMU's ``doStep`` through
   fmpy, and a two-step batch least-squares re-solve over all N samples;
3. accuracy: estimates at 20 s and 60 s and the time each parameter enters 0.1 % for good,
   both robots, both methods, both acceleration sources, beside the paper's printed values;
4. memory: resident set size of a long spatial co-simulation at 60 / 300 / 600 s.

No timing is asserted anywhere; the numbers describe this machine at the time of the run (the
report records the machine and its load average, as other processes may share the CPU).

Usage: ``python benchmarks/run.py [--quick] [--memory-seconds 600] [--out benchmarks/REPORT.md]``
"""
from __future__ import annotations

import argparse
import cProfile
import gc
import datetime as _dt
import io
import json
import math
import os
import platform
import pstats
import shutil
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

from spacerobot import (ESTIMATE_NAMES, PAPER_PLANAR_MEDIUM, FMUInstance,  # noqa: E402
                        Identifier, Master, Plant, estimate_vector, identified_estimates,
                        relative_errors, run_ssp, scenario)
from spacerobot.robots import PLANAR  # noqa: E402
from spacerobot.system.instance import ArrayIO  # noqa: E402

NAMES = list(ESTIMATE_NAMES)
#: parameters the planar model identifies (x, y translation, z rotation)
PLANAR_IDENTIFIED = [NAMES.index(n) for n in identified_estimates(PLANAR)]
#: estimator variants of the accuracy study: (label, method, solver, accel_source)
VARIANTS = [("momentum", "momentum", "paper", "measured"),
            ("force, measured acc.", "force", "paper", "measured"),
            ("force, differenced acc.", "force", "paper", "differenced"),
            ("momentum, joint RLS", "momentum", "joint", "measured"),
            ("force, measured acc., joint RLS", "force", "joint", "measured"),
            ("force, differenced acc., joint RLS", "force", "joint", "differenced")]


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------

def machine() -> dict:
    import fmpy
    import pinocchio
    cpu = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__,
            "pinocchio": pinocchio.__version__,
            "fmpy": fmpy.__version__, "platform": platform.platform(),
            "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "load": os.getloadavg()}


def new_plant(sc) -> Plant:
    return Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)


def record_outputs(sc, seconds: float, dt: float = 0.1) -> list:
    p = new_plant(sc)
    n = int(round(seconds / dt))
    outs = [p.outputs()]
    for _ in range(n):
        p.advance(dt)
        outs.append(p.outputs())
    return outs


def bare_rk4(sc, seconds: float) -> tuple:
    """``(CPU s, wall s)`` of a bare RK4 loop over pin.aba (zero torques) on the plant's model,
    at the plant's step, from the plant's initial state: Pinocchio called from Python."""
    import pinocchio as pin
    if str(ROOT / "tests") not in sys.path:
        sys.path.insert(0, str(ROOT / "tests"))
    from oracles.pinocchio_model import build_model        # the plant's model on Pinocchio
    p = new_plant(sc)
    model = build_model(sc.robot, sc.robot.base, sc.target).model
    data = model.createData()
    q, v = p.q.copy(), p.v.copy()
    tau = np.zeros(model.nv)
    h = sc.h
    n = int(round(seconds / h))
    t0, w0 = time.process_time(), time.perf_counter()
    for _ in range(n):
        a1 = pin.aba(model, data, q, v, tau)
        v2 = v + 0.5 * h * a1
        a2 = pin.aba(model, data, pin.integrate(model, q, 0.5 * h * v), v2, tau)
        v3 = v + 0.5 * h * a2
        a3 = pin.aba(model, data, pin.integrate(model, q, 0.5 * h * v2), v3, tau)
        v4 = v + h * a3
        a4 = pin.aba(model, data, pin.integrate(model, q, h * v3), v4, tau)
        q = pin.integrate(model, q, h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4))
        v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return time.process_time() - t0, time.perf_counter() - w0


def started(path: Path, name: str) -> FMUInstance:
    """An :class:`FMUInstance` initialised with its default parameters."""
    return FMUInstance(path, name).init()


def pair(plant_fmu: Path, estimator_fmu: Path) -> Master:
    """Plant and estimator (default parameters) wired name to name by the co-simulation loop."""
    plant, est = started(plant_fmu, "plant"), started(estimator_fmu, "estimator")
    return Master({"plant": plant, "estimator": est},
                  [("plant", n, "estimator", n) for n in est.names("input")])


def build_systems(robots, out: Path) -> dict:
    from spacerobot import build_system
    paths = {}
    for r in robots:
        paths[r] = build_system(r, out / r)
    return paths


def fmt(x: float, nd: int = 1) -> str:
    return f"{x:.{nd}f}"


def table(header, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


# ------------------------------------------------------------------------------------------------
# 1. co-simulation speed
# ------------------------------------------------------------------------------------------------

def cosim_speed(systems: dict, seconds: dict, repeats: int) -> dict:
    """run_ssp at two stop times (the difference removes instantiation and set-up) and the bare
    RK4 loop, interleaved, best of ``repeats``; plus a per-component breakdown."""
    gc.collect()               # start every round with no garbage of earlier sections
    res = {}
    for robot, ssp_paths in systems.items():
        sc = scenario(robot)
        T = seconds[robot]
        T0 = 1.0
        # warm-up: the first run in a process loads the compiled kernels (or compiles them on
        # a machine's very first run); that one-off cost is not part of either measured run
        run_ssp(ssp_paths["ssp"], stop_time=0.2, progress=False)
        wall_short, wall_long, cpu_short, cpu_long, bare, bare_wall = [], [], [], [], [], []
        for _ in range(repeats):
            t, c = time.perf_counter(), time.process_time()
            run_ssp(ssp_paths["ssp"], stop_time=T0, progress=False)
            wall_short.append(time.perf_counter() - t)
            cpu_short.append(time.process_time() - c)
            t, c = time.perf_counter(), time.process_time()
            run_ssp(ssp_paths["ssp"], stop_time=T0 + T, progress=False)
            wall_long.append(time.perf_counter() - t)
            cpu_long.append(time.process_time() - c)
            b_cpu, b_wall = bare_rk4(sc, T)
            bare.append(b_cpu)
            bare_wall.append(b_wall)
        steps = T / sc.h
        cpu_marginal = min(cpu_long) - min(cpu_short)        # CPU s per T simulated seconds
        wall_marginal = min(wall_long) - min(wall_short)
        bare_step = min(bare) / steps
        cos_step = cpu_marginal / steps
        res[robot] = {"T": T, "setup_s": min(wall_short) - T0 * wall_marginal / T,
                      "cosim_us_per_step": cos_step * 1e6, "bare_us_per_step": bare_step * 1e6,
                      "ratio": cos_step / bare_step, "rtf": T / wall_marginal,
                      "ratio_wall": wall_marginal / min(bare_wall),
                      "rtf_cpu": T / cpu_marginal, "rtf_bare": T / min(bare),
                      "rtf_total": (T0 + T) / min(wall_long)}
        res[robot]["breakdown"] = breakdown(ssp_paths, sc, min(T, 10.0))
    return res


def merge_rounds(rounds: list) -> dict:
    """Per robot, the round with the median ratio (the host's speed drifts between rounds, so
    the ratio, the real-time factors and their times are that round's), plus every round's
    ratio. The breakdown's parts (CPU costs, each already a best of several blocks) are the
    least over the rounds: a round's breakdown runs after its ratio, sometimes in a slower
    phase of the host than the ratio it follows."""
    out = {}
    for robot in rounds[0]:
        rs = sorted((r[robot] for r in rounds), key=lambda x: x["ratio"])
        pick = dict(rs[(len(rs) - 1) // 2])
        pick["ratios"] = [r[robot]["ratio"] for r in rounds]
        pick["rounds"] = len(rounds)
        parts = dict(pick["breakdown"])
        for key in parts:
            if key != "excite_level":
                parts[key] = min(r[robot]["breakdown"][key] for r in rounds)
        pick["breakdown"] = parts
        out[robot] = pick
    return out


def breakdown(ssp_paths: dict, sc, seconds: float) -> dict:
    """Where one communication step (0.1 s) goes: the system built from the ``.ssp`` as
    ``run_ssp`` builds it (its parameter set, connections and recorder), stepped as
    ``Master.run`` steps it with a timer around each part (the exchange, the recording, each
    component's ``fmi2DoStep``, the rest of the loop); then the cores alone."""
    from spacerobot.system import runner
    from spacerobot.system.errors import Calls
    from spacerobot.system.instance import FMULog
    from spacerobot.system.master import Master, initialize
    from spacerobot.system.recorder import Recorder

    tmp = Path(tempfile.mkdtemp(prefix="bench_breakdown_"))
    dt = 0.1
    n = int(round(seconds / dt))
    insts = {}
    try:
        root_dir, info = runner.open_system(Path(ssp_paths["ssp"]), tmp)
        _, chosen = runner.chosen_values(info, root_dir, None)
        log, calls = FMULog(), Calls()
        for name, comp in info.components.items():
            insts[name] = runner._instance(comp, root_dir, tmp, log)
            insts[name].instantiate()
            runner.apply_component_bindings(insts[name], comp, chosen, calls)
        runner.apply_system_bindings(insts, info, calls)
        initialize(insts, 0.0, (n + 1) * dt, calls)
        master = Master(insts, info.connections, calls)
        recorder = Recorder(insts, runner._recorded(info, insts), n + 1, calls)
        plant, est = insts["plant"], insts["estimator"]
        # the standard deviations alone (part of the recording above; computed in the doStep)
        sd_vr = [v.valueReference for v in est.vars.values()
                 if v.causality == "output" and v.name.startswith("sd.")]
        sd_read = ArrayIO(est.fmu, "Real", sd_vr)
        steps = dict(master._steps)
        keys = ("exchange", "record", "plant_doStep", "estimator_doStep", "loop_rest")
        per = {k: math.inf for k in keys}
        sd_cost = math.inf
        t, k = 0.0, 0
        block = max(1, n // 8)
        for _ in range(8):                 # best of 8 blocks of n/8 communication steps
            tt = dict.fromkeys(keys, 0.0)
            for _ in range(block):
                c0 = time.process_time()
                calls.t = t
                master.exchange()
                c1 = time.process_time()
                recorder.record(k, t)
                c2 = time.process_time()
                steps["plant"](t, dt)
                c3 = time.process_time()
                steps["estimator"](t, dt)
                c4 = time.process_time()
                t, k = t + dt, k + 1
                c5 = time.process_time()
                for key, d in zip(keys, (c1 - c0, c2 - c1, c3 - c2, c4 - c3, c5 - c4)):
                    tt[key] += d
            for key in keys:
                per[key] = min(per[key], tt[key] / block * 1e6)      # us per communication step
            c = time.process_time()
            for _ in range(20):
                sd_read.get()
            sd_cost = min(sd_cost, (time.process_time() - c) / 20 * 1e6)
        per["record_sd"] = sd_cost
        per["excite_level"] = float(plant.get("excite.level"))       # at the end of the loop
    finally:
        for inst in insts.values():
            inst.free()
        shutil.rmtree(tmp, ignore_errors=True)
    # the cores alone, same scenario and length (best of 8 blocks): the plant without and with
    # the excitation at full level (which the spatial system's estimator requests)
    for key, level in (("plant_core", 0.0), ("plant_core_excited", 1.0)):
        p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  sc.excitation)
        p.set_excitation(level)
        for _ in range(int(round(sc.excitation.ramp / dt))):      # past the ramp
            p.advance(dt)
        best = math.inf
        for _ in range(8):
            c = time.process_time()
            for _ in range(block):
                p.advance(dt)
            best = min(best, (time.process_time() - c) / block)
        per[key] = best * 1e6
    outs = record_outputs(sc, n * 0.1)
    per["estimator_core"] = core_update_cost(outs, sc, "momentum", repeats=4)
    per["estimator_report"] = core_report_cost(outs, sc, repeats=4)
    return per


def core_report_cost(outs: list, sc, repeats: int = 3) -> float:
    """CPU microseconds of ``Identifier.report()`` (physical projection, standard deviations,
    identified flags) after each sample, as the estimator FMU computes it at every step."""
    best = math.inf
    for _ in range(repeats):
        ident = Identifier(sc.robot, sc.guess, method="momentum")
        spent = 0.0
        for k, o in enumerate(outs):
            ident.update(0.1 * k, o)
            c = time.process_time()
            ident.report()
            spent += time.process_time() - c
        best = min(best, spent / len(outs))
    return best * 1e6


def profile_summary(ssp_path: Path, seconds: float, top: int = 14) -> str:
    """cProfile of a run_ssp run (the FMUs' Python code runs in this interpreter)."""
    pr = cProfile.Profile()
    pr.enable()
    run_ssp(ssp_path, stop_time=seconds, progress=False)
    pr.disable()
    s = io.StringIO()
    st = pstats.Stats(pr, stream=s)
    total = sum(v[2] for v in st.stats.values())
    rows = []
    for (fn, line, name), (cc, nc, tottime, cumtime, _) in sorted(
            st.stats.items(), key=lambda kv: -kv[1][2])[:top]:
        where = fn.replace(str(ROOT) + "/", "")
        for marker in ("site-packages/", "/lib/python3"):
            if marker in where:
                where = where.split(marker, 1)[1]
        if "resources/" in where:
            where = "FMU:" + where.split("resources/", 1)[1]
        rows.append((f"`{name}`", f"`{where}:{line}`", nc, fmt(tottime / total * 100, 1)))
    return (f"Profiled CPU time (cProfile, inflates small calls): {total:.2f} s for "
            f"{seconds:g} s simulated.\n\n"
            + table(["function", "where", "calls", "% self time"], rows))


# ------------------------------------------------------------------------------------------------
# 2. estimator cost per sample
# ------------------------------------------------------------------------------------------------

def core_update_cost(outs: list, sc, method: str, solver: str = "paper", repeats: int = 3) -> float:
    best = math.inf
    for _ in range(repeats):
        ident = Identifier(sc.robot, sc.guess, method=method, solver=solver)
        c = time.process_time()
        for k, o in enumerate(outs):
            ident.update(0.1 * k, o)
        best = min(best, (time.process_time() - c) / len(outs))
    return best * 1e6


def fmu_dostep_cost(est_fmu: Path, outs: list, names: list, repeats: int = 3) -> dict:
    """Estimator FMU alone through fmpy: setReal of the inputs, doStep, getReal of the
    estimates, per sample [us]."""
    keys = {"base.r": "r_S", "base.v": "v_S", "base.A": "A", "base.omega": "omega_B",
            "base.a": "a_S", "base.alpha": "alpha_B", "arm.q": "q", "arm.qd": "qd",
            "arm.qdd": "qdd", "thrust.F": "F", "thrust.M": "M", "thrust.J": "J",
            "thrust.H": "H"}

    def value(o, name):
        stem, idx = name.split("[")
        idx = [int(i) - 1 for i in idx.rstrip("]").split(",")]
        x = o[keys[stem]]
        return float(x[idx[0], idx[1]] if len(idx) == 2 else x[idx[0]])

    rows = [[value(o, n) for n in names] for o in outs]
    best = {"setReal": math.inf, "doStep": math.inf, "getReal": math.inf}
    for _ in range(repeats):
        est = started(est_fmu, "estimator")
        try:
            vr = est.vrs(names)
            out_vr = est.vrs([n for n in NAMES if n in est.vars])
            acc = {"setReal": 0.0, "doStep": 0.0, "getReal": 0.0}
            t = 0.0
            for r in rows:
                c = time.process_time()
                est.fmu.setReal(vr, r)
                c1 = time.process_time()
                est.fmu.doStep(t, 0.1)
                c2 = time.process_time()
                est.fmu.getReal(out_vr)
                c3 = time.process_time()
                acc["setReal"] += c1 - c
                acc["doStep"] += c2 - c1
                acc["getReal"] += c3 - c2
                t += 0.1
        finally:
            est.free()
        for k in best:
            best[k] = min(best[k], acc[k] / len(rows) * 1e6)
    return best


def batch_cost(outs: list, sc, Ns, repeats: int = 5) -> dict:
    """The two-step batch alternative (momentum form): stack the rows of all N samples,
    lstsq for mu, then lstsq for theta with y + psi D(mu): seconds per re-solve at N. The rows
    come from the NumPy oracle estimator of the tests (tests/oracles/estimator; the native core
    keeps its equations internal): only the re-solves are timed."""
    if str(ROOT / "tests") not in sys.path:
        sys.path.insert(0, str(ROOT / "tests"))
    from oracles.estimator import parameters as rg
    from oracles.estimator import Identifier as OracleIdentifier
    ident = OracleIdentifier(sc.robot, sc.guess, method="momentum")
    rows = []
    for k, o in enumerate(outs):
        s = {key: np.array(o[key], float) for key in o}
        eq = ident.equations(s)
        if eq is not None:
            rows.append(eq)
    rl, ra = ident.layout.rows_lin, ident.layout.rows_ang
    mi, ti = ident.layout.mu_active, ident.layout.theta_active
    res = {}
    for N in Ns:
        if N > len(rows):
            continue
        sub = rows[:N]
        best = math.inf
        for _ in range(repeats):
            c = time.perf_counter()
            A = np.concatenate([r[0][rl][:, mi] for r in sub])
            b = np.concatenate([r[1][rl] for r in sub])
            mu_a = np.linalg.lstsq(A, b, rcond=None)[0]
            mu = rg.paper_vectors(sc.guess)[0]
            mu[mi] = mu_a
            D = rg.D_of_mu(mu)
            phi = np.concatenate([r[2][ra][:, ti] for r in sub])
            y = np.concatenate([r[3][ra] + r[4][ra].dot(D) for r in sub])
            np.linalg.lstsq(phi, y, rcond=None)
            best = min(best, time.perf_counter() - c)
        res[N] = best * 1e6
    return res


# ------------------------------------------------------------------------------------------------
# 3. accuracy
# ------------------------------------------------------------------------------------------------

def accuracy(robot: str, seconds: float = 60.0) -> dict:
    sc = scenario(robot)
    truth = estimate_vector(sc.robot.base, sc.target)
    idx = PLANAR_IDENTIFIED if sc.robot.planar else list(range(20))
    p = new_plant(sc)
    ids = {lab: Identifier(sc.robot, sc.guess, method=m, solver=s, accel_source=a)
           for lab, m, s, a in VARIANTS}
    n = int(round(seconds / 0.1))
    hist = {lab: np.empty((n + 1, 20)) for lab in ids}
    times = np.arange(n + 1) * 0.1
    for k in range(n + 1):
        o = p.outputs()
        for lab, ident in ids.items():
            ident.update(times[k], o)
            hist[lab][k] = ident.vector()
        if k < n:
            p.advance(0.1)
    out = {"truth": truth, "idx": idx, "variants": {}}
    for lab, H in hist.items():
        err = relative_errors(H, truth)
        k20 = int(round(20.0 / 0.1))
        transit = []
        for i in range(20):
            bad = np.nonzero(err[:, i] > 1e-3)[0]
            if len(bad) == 0:
                transit.append(0.0)
            elif bad[-1] == n:
                transit.append(math.inf)
            else:
                transit.append(times[bad[-1] + 1])
        out["variants"][lab] = {"at20": H[min(k20, n)], "at60": H[n],
                                "err20": err[min(k20, n)], "err60": err[n],
                                "transit": np.array(transit)}
    return out


# ------------------------------------------------------------------------------------------------
# 4. memory
# ------------------------------------------------------------------------------------------------

MEMORY_CHILD = r"""
import json, resource, sys, time
import psutil
sys.path.insert(0, sys.argv[1])
from benchmarks.run import pair
from pathlib import Path
master = pair(Path(sys.argv[2]), Path(sys.argv[3]))
plant, est = master.instances["plant"], master.instances["estimator"]
marks = [float(x) for x in sys.argv[4].split(",")]
outs = [v.valueReference for v in est.vars.values() if v.causality == "output" and v.type == "Real"]
proc = psutil.Process()
res = [{"t": 0.0, "rss_MB": proc.memory_info().rss / 2**20,
        "maxrss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}]
t, k, c0 = 0.0, 0, time.perf_counter()
for mark in marks:
    while t < mark - 1e-9:
        master.step(t, 0.1)
        est.fmu.getReal(outs)
        k += 1; t = k * 0.1
    res.append({"t": round(t, 6), "rss_MB": proc.memory_info().rss / 2**20,
                "maxrss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                "wall_s": time.perf_counter() - c0})
plant.free(); est.free()
print(json.dumps(res))
"""


def memory(system: dict, seconds: float) -> list:
    marks = [m for m in (10.0, 60.0, 300.0, 600.0, 1200.0) if m <= seconds]
    if seconds not in marks:
        marks.append(seconds)
    out = subprocess.run([sys.executable, "-c", MEMORY_CHILD, str(ROOT), str(system["plant"]),
                          str(system["estimator"]), ",".join(str(m) for m in marks)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# ------------------------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------------------------

def accuracy_table(robot: str, a: dict, labs, values: bool) -> str:
    """Per-parameter table: estimates (planar, beside the paper) or errors at 20 s and 60 s,
    and the transit time, for the variants ``labs``."""
    truth, idx = a["truth"], a["idx"]
    head = ["parameter", "truth"] + (["paper, momentum", "paper, force"] if values else [])
    for lab in labs:
        head += [f"{lab}: 20 s", "60 s", "transit [s]"]
    rows = []
    for i in idx:
        name = NAMES[i]
        row = [f"`{name}`", f"{truth[i]:.6g}"]
        if values:
            row += [PAPER_PLANAR_MEDIUM["momentum"].get(name, ""),
                    PAPER_PLANAR_MEDIUM["force"].get(name, "")]
        for lab in labs:
            v = a["variants"][lab]
            if values:
                row += [f"{v['at20'][i]:.5g}", f"{v['at60'][i]:.5g}"]
            else:
                row += [f"{v['err20'][i] * 100:.3f} %", f"{v['err60'][i] * 100:.3f} %"]
            row.append("never" if not math.isfinite(v["transit"][i]) else fmt(v["transit"][i], 1))
        rows.append(row)
    note = ("Estimates in SI units (the paper prints the CoM inertia Izz)." if values else
            "Relative errors.")
    return note + "\n\n" + table(head, rows)


#: repetitions of each timed run (short, long, bare loop, interleaved) in a speed round; the
#: host's speed drifts within seconds, and the best of more repetitions is steadier
SPEED_REPEATS = 7
#: rounds of the speed measurement, spread over the run (the round with the median ratio is shown)
SPEED_ROUNDS = 5


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs (smoke test of the script)")
    ap.add_argument("--memory-seconds", type=float, default=600.0,
                    help="length of the memory run [s]; 0 skips it (default 600)")
    ap.add_argument("--out", default=str(HERE / "REPORT.md"))
    ap.add_argument("--build-dir", default=None, help="where to build the FMUs/SSPs (temp dir)")
    args = ap.parse_args(argv)
    quick = args.quick
    t_start = time.perf_counter()
    info = machine()
    print(f"machine: {info['cpu']}, {info['cores']} cores, load {info['load']}", flush=True)
    build = Path(args.build_dir) if args.build_dir else Path(tempfile.mkdtemp(prefix="srbench_"))
    systems = build_systems(("planar", "spatial"), build)
    print(f"built FMUs and SSPs in {build}", flush=True)

    # 1. speed
    seconds = {"planar": 3.0, "spatial": 3.0} if quick else {"planar": 10.0, "spatial": 10.0}
    # measured in SPEED_ROUNDS rounds spread over the run (now, after sections 2, 3 and 4,
    # and once more at the end) and merged by taking the round with the median ratio: the
    # host's speed drifts for seconds at a time
    rounds = [cosim_speed(systems, seconds, repeats=1 if quick else SPEED_REPEATS)]
    print("speed:", {r: round(v["ratio"], 2) for r, v in rounds[-1].items()}, flush=True)
    prof = profile_summary(systems["spatial"]["ssp"], 2.0 if quick else 10.0)

    # 2. estimator cost
    rec_s = 10.0 if quick else 60.0
    outs = {r: record_outputs(scenario(r), rec_s) for r in ("planar", "spatial")}
    est_cost = {}
    for r in ("planar", "spatial"):
        sc = scenario(r)
        from fmpy import read_model_description
        est_names = [v.name for v in read_model_description(
            str(systems[r]["estimator"])).modelVariables if v.causality == "input"]
        reps = 1 if quick else 5
        est_cost[r] = {
            "core_momentum": core_update_cost(outs[r], sc, "momentum", repeats=reps),
            "core_force": core_update_cost(outs[r], sc, "force", repeats=reps),
            "core_momentum_joint": core_update_cost(outs[r], sc, "momentum", "joint",
                                                    repeats=reps),
            "fmu": fmu_dostep_cost(systems[r]["estimator"], outs[r], est_names, repeats=reps),
        }
    Ns = (100, 600) if quick else (100, 600, 6000)
    long_s = 65.0 if quick else 605.0
    long_outs = outs["spatial"] if quick else record_outputs(scenario("spatial"), long_s)
    batch = batch_cost(long_outs, scenario("spatial"), Ns)
    print("estimator:", {r: round(v["core_momentum"], 1) for r, v in est_cost.items()}, flush=True)
    # release the recorded samples (~10^5 live Python objects) before the next speed rounds:
    # every cyclic-GC pass of the co-simulation would otherwise walk them, a cost of this
    # script's bookkeeping, not of the product
    del outs, long_outs
    gc.collect()

    if not quick:
        rounds.append(cosim_speed(systems, seconds, repeats=SPEED_REPEATS))
    # 3. accuracy
    acc = {r: accuracy(r, 25.0 if quick else 60.0) for r in ("planar", "spatial")}
    if not quick:
        rounds.append(cosim_speed(systems, seconds, repeats=SPEED_REPEATS))
    print("accuracy done", flush=True)

    # 4. memory
    mem = memory(systems["spatial"], args.memory_seconds) if args.memory_seconds > 0 else None
    print("memory:", mem, flush=True)
    while not quick and len(rounds) < SPEED_ROUNDS:
        rounds.append(cosim_speed(systems, seconds, repeats=SPEED_REPEATS))
    speed = merge_rounds(rounds)
    print("speed rounds:", [{r: round(v["ratio"], 2) for r, v in x.items()} for x in rounds],
          "merged:", {r: round(v["ratio"], 2) for r, v in speed.items()}, flush=True)
    info["load_end"] = os.getloadavg()
    info["runtime_s"] = time.perf_counter() - t_start
    Path(args.out).write_text(render(info, speed, prof, est_cost, batch, acc, mem, quick))
    print(f"wrote {args.out} in {info['runtime_s']:.0f} s")
    return 0


def _before_table(path: Path, speed: dict) -> str:
    """The same co-simulation figures of an earlier tree (``path``: a saved
    :func:`merge_rounds` result), against this run; empty if there is no such file."""
    if not path.exists():
        return ""
    base = json.loads(path.read_text())
    meta = base.get("_meta", {})
    rows = []
    for r, v in speed.items():
        if r not in base:
            continue
        b = base[r]
        bb, vb = b["breakdown"], v["breakdown"]
        rows.append((r, f"{b['ratio']:.2f} -> **{v['ratio']:.2f}**",
                     f"{b['cosim_us_per_step']:.1f} -> {v['cosim_us_per_step']:.1f}",
                     f"{b['rtf']:.0f} -> {v['rtf']:.0f}",
                     f"{bb['plant_core'] / 100:.1f} -> {vb['plant_core'] / 100:.1f}",
                     f"{bb['plant_doStep']:.0f} -> {vb['plant_doStep']:.0f}",
                     f"{bb['estimator_doStep']:.0f} -> {vb['estimator_doStep']:.0f}"))
    return (f"Before issue #16 ({meta.get('what', '')}; {meta.get('date', '')}), against this "
            "run (the ratios of that tree were measured against its own bare loop in its own "
            "run):\n\n" + table(["robot", "ratio to bare RK4 (CPU)", "co-simulation [CPU us / "
                                 "1 ms step]", "real-time factor (wall)", "plant core [us / RK4 "
                                 "step]", "plant FMU doStep [us / 0.1 s]", "estimator FMU "
                                 "doStep [us / 0.1 s]"], rows) + "\n")


def render(info, speed, prof, est_cost, batch, acc, mem, quick) -> str:
    L = []
    L.append("# Benchmarks (issues #6, #16)\n")
    L.append("Generated by `python benchmarks/run.py`" + (" --quick" if quick else "")
             + "; do not edit by hand. No timing is asserted by any test; these figures "
             "describe one run on one machine.\n")
    L.append("## Machine\n")
    L.append(table(["item", "value"], [
        ("CPU", info["cpu"]), ("cores (os.cpu_count)", info["cores"]),
        ("platform", info["platform"]), ("Python", info["python"]), ("numpy", info["numpy"]),
        ("pinocchio", info["pinocchio"]), ("fmpy", info["fmpy"]),
        ("date", info["date"]),
        ("load average (1/5/15 min) at start", " / ".join(f"{x:.2f}" for x in info["load"])),
        ("load average at end", " / ".join(f"{x:.2f}" for x in info["load_end"])),
        ("benchmark run time", f"{info['runtime_s']:.0f} s")]))
    L.append("\nThe load average shows whether other processes shared the CPU during the run; "
             "CPU-time (`time.process_time`) is used wherever only this process's work counts, "
             "and the best of several repeats is reported. This machine is a 2-vCPU virtual "
             "machine whose speed drifts: between runs of this script on a quiet guest, the "
             "same bare RK4 loop took 15 to 22 us per step. Ratios measured within one round "
             "are steadier than absolute times.\n")

    # 1
    L.append("## 1. Co-simulation speed\n")
    L.append("Whole system = `spacerobot.run_ssp` on the packaged `.ssp` (plant FMU "
             "and estimator FMU through fmpy, communication step 0.1 s, every output recorded at "
             "every step, as the product runs). Its cost per simulated second is the difference "
             "of two runs (1 s and 1 s + T), which removes extraction, instantiation and "
             "initialisation (reported separately). Floor = a bare RK4 loop over `pin.aba` "
             "(zero torques, `pin.integrate` for the configuration) on the same Pinocchio model, "
             "1 ms step, same initial state. Measured in the same process, interleaved, in "
             f"{SPEED_ROUNDS} rounds spread over the benchmark run "
             f"(best of {SPEED_REPEATS} repetitions in each round); the round with the median ratio is shown, as "
             "the host's speed drifts between rounds (1 round of 1 in --quick).\n")
    rows = []
    for r, v in speed.items():
        rows.append((r, fmt(v["T"], 0), fmt(v["bare_us_per_step"]), fmt(v["cosim_us_per_step"]),
                     f"**{v['ratio']:.2f}**", f"{v.get('ratio_wall', math.nan):.2f}",
                     fmt(v["rtf_bare"], 0), fmt(v["rtf_cpu"], 1),
                     fmt(v["rtf"], 1), fmt(v["rtf_total"], 1), fmt(v["setup_s"], 2)))
    L.append(table(["robot", "T [s]", "bare RK4 [CPU us / 1 ms step]", "co-simulation "
                    "[CPU us / 1 ms step]", "ratio (CPU)", "ratio (wall)",
                    "real-time factor, bare RK4 (CPU)",
                    "real-time factor, co-simulation (CPU)", "real-time factor, co-simulation "
                    "(wall)", "real-time factor incl. set-up, 1 s + T (wall)", "set-up [s]"],
                   rows))
    L.append("\nRatio = co-simulation CPU time / bare RK4 CPU time for the same simulated time "
             "(both in this process; the wall-time ratio beside it). Real-time factor = simulated "
             "seconds per second. Ratio (CPU) of each round: "
             + "; ".join(f"{r} " + ", ".join(f"{x:.2f}" for x in v.get("ratios", []))
                         for r, v in speed.items())
             + ". Target of issue #16: ratio <= 0.3 (spatial, 10 s).\n")
    L.append(_before_table(HERE / "baseline_i16.json", speed))
    base_file = HERE / "baseline_before.json"
    if base_file.exists():
        base = json.loads(base_file.read_text())
        meta = base.get("_meta", {})
        L.append(f"Before the performance work of issue #6 ({meta.get('what', '')}; {meta.get('date', '')}), "
                 "against this run:\n")
        rows = []
        for r in speed:
            if r not in base:
                continue
            b, v = base[r], speed[r]
            bb, vb = b["breakdown"], v["breakdown"]
            rows.append((r, f"{b['ratio']:.2f} -> **{v['ratio']:.2f}**",
                         f"{b['cosim_us_per_step']:.0f} -> {v['cosim_us_per_step']:.0f}",
                         f"{b['rtf_cpu']:.1f} -> {v['rtf_cpu']:.1f}",
                         f"{bb['plant_core'] / 100:.0f} -> {vb['plant_core'] / 100:.1f}",
                         f"{bb['estimator_core']:.0f} -> {vb['estimator_core']:.0f}",
                         f"{bb['estimator_doStep']:.0f} -> {vb['estimator_doStep']:.0f}",
                         f"{bb['record_sd']:.0f} -> {vb['record_sd']:.0f}"))
        L.append(table(["robot", "ratio to bare RK4", "co-simulation [CPU us / 1 ms step]",
                        "real-time factor (CPU)", "plant core [us / RK4 step]",
                        "estimator core [us / sample]", "estimator FMU doStep [us]",
                        "standard deviations read [us / 0.1 s]"], rows) + "\n")
    L.append("### Where the time goes (per 0.1 s communication step, CPU microseconds)\n")
    L.append("The system built from the `.ssp` as `run_ssp` builds it (its parameter set, "
             "connections and recorder) and stepped as `Master.run` steps it, with a timer "
             "around each part; and the two cores alone on the same scenario; best of 8 blocks "
             "of 12 communication steps (the estimator core: best of 4 passes over 10 s of "
             "samples); each part the least of the rounds (a round's breakdown follows its "
             "ratio, sometimes in a slower phase of the host).\n")
    rows = []
    keys = [("plant_core", "plant core alone: `Plant.advance(0.1)` (100 RK4 steps, no excitation)"),
            ("plant_core_excited", "plant core alone, excitation at level 1 (the spatial "
                                   "estimator requests it)"),
            ("plant_doStep", "plant FMU `doStep` through fmpy (closed loop)"),
            ("estimator_core", "estimator core alone: `Identifier.update`"),
            ("estimator_report", "estimator core alone: `Identifier.report()` after each update"),
            ("estimator_doStep", "estimator FMU `doStep` through fmpy (update + report)"),
            ("exchange", "wiring: plant outputs -> estimator inputs, `ident.excite` back"),
            ("record", "recording: every connector and output (`Recorder.record`, as `run_ssp`)"),
            ("record_sd", "  of which the standard deviations alone (computed in the `doStep`)"),
            ("loop_rest", "the rest of the loop")]
    for k, lab in keys:
        nd = 2 if k.endswith("_call") else 0
        rows.append((lab,) + tuple(fmt(speed[r]["breakdown"].get(k, math.nan), nd)
                                   for r in speed))
    L.append(table(["part"] + [f"{r} [us]" for r in speed], rows))
    per_step = "; ".join(
        f"{r} {v['breakdown']['plant_core'] / 100:.1f} us = "
        f"{v['breakdown']['plant_core'] / 100 / v['bare_us_per_step']:.2f} x the floor"
        for r, v in speed.items())
    shares, budget = [], []
    for r, v in speed.items():
        b = v["breakdown"]
        parts = {"plant FMU doStep": b["plant_doStep"], "estimator FMU doStep":
                 b["estimator_doStep"], "wiring, recording and loop": b["exchange"] + b["record"]
                 + b.get("loop_rest", 0.0)}
        tot = sum(parts.values())
        shares.append(f"{r}: {tot:.0f} us = " + ", ".join(
            f"{k} {x / tot * 100:.0f} %" for k, x in parts.items()))
        floor = v["bare_us_per_step"] * 100                 # the floor per 0.1 s
        budget.append(f"{r} at most {0.3 * floor:.0f} us, while the plant FMU's `doStep` "
                      f"alone takes {b['plant_doStep']:.0f} us ({b['plant_doStep'] / floor:.2f} "
                      f"x the floor) and the estimator's `doStep` "
                      f"{b['estimator_doStep']:.0f} us")
    L.append("\nThe plant is the native C core (`native/src/plant.c`, through ctypes in the "
             "library and behind the FMI layer in the plant FMU): one call advances a whole "
             "communication step; per 1 ms RK4 step the rigid-body terms (M, non-linear "
             "effects, centroidal momentum; `native/src/dynamics.c`) and the controllers, whose "
             "inverse dynamics give the first stage's accelerations, then three "
             "articulated-body (ABA) evaluations for the other stages. Plant core per RK4 step "
             f"(this breakdown, against the floor of the table above): {per_step}. "
             f"Sum of the measured parts per communication step: "
             f"{'; '.join(shares)}. In these systems the estimator requests the excitation "
             "until it has identified both bodies, so the plant evaluates the multi-sine "
             "references at every RK4 step (their sines afresh every 20 steps and rotated by "
             "the step in between): excitation level at the end of the "
             "loop "
             + ", ".join(f"{r} {v['breakdown'].get('excite_level', math.nan):.2f}"
                         for r, v in speed.items()) + ". "
             "The estimator FMU is the native one (issue #26, the default of `spacerobot "
             "build`): its `doStep` is the C core's update (the equations, the modified RLS, the "
             "Gram and information sums, the standard deviations with the prior's pull from the "
             "scaled 8x8 and 12x12 information (while it is poorly conditioned its "
             "eigen-decompositions, then its extreme eigenvalues and a Cholesky factor), the "
             "tracker of the estimates' lag) and its report (physical test and identified flags), every step, "
             "since the excitation request and the identified flags depend on them; the FMI "
             "layer serves `fmi2GetReal` / `fmi2SetReal` from arrays indexed by value reference "
             "(native/fmi/fmi_layer.c). The master reads and writes every connected "
             "variable and every recorded output with one FMI call per component and type "
             "through preallocated arrays (`spacerobot/system/instance.py` `ArrayIO`). For "
             f"the ratio target 0.3 the whole communication step would have to cost "
             f"{'; '.join(budget)}.\n")
    L.append("### Profile of a spatial run_ssp run (10 s)\n" if not quick else
             "### Profile of a spatial run_ssp run\n")
    L.append(prof + "\n")

    # 2
    L.append("## 2. Estimator cost per sample\n")
    L.append("Core = `Identifier.update` (the library's Python class over the native C core) "
             "on recorded plant outputs (60 s, CPU time per sample, "
             "best of 5 passes, paper solver unless stated). FMU = the estimator FMU of the "
             "system (`benchmarks/NATIVE.md` compares the FMU and both cores in one run) "
             "alone through fmpy: "
             "`setReal` of the inputs, `doStep` (which runs `update` and refreshes the outputs), "
             "`getReal` of the 20 estimates.\n")
    rows = []
    for r, v in est_cost.items():
        rows.append((r, fmt(v["core_momentum"]), fmt(v["core_force"]),
                     fmt(v["core_momentum_joint"]), fmt(v["fmu"]["setReal"]),
                     fmt(v["fmu"]["doStep"]), fmt(v["fmu"]["getReal"])))
    L.append(table(["robot", "core, momentum [us]", "core, force [us]",
                    "core, momentum, joint RLS [us]", "FMU setReal [us]", "FMU doStep [us]",
                    "FMU getReal estimates [us]"], rows))
    L.append("\nThe core update is one call of the native C core (`native/src/estimator.c`, "
             "through `spacerobot.core.estimator.NativeEstimator` in the library): the "
             "validation of the sample, the equations (`native/src/equations.c`: arm "
             "kinematics, arm momentum or rate of momentum, regressors of both bodies), the "
             "modified RLS step, the standard deviations of the new estimates with the prior's "
             "pull and the eigen-decompositions of the scaled information, and the tracker of "
             "their lag behind moving parameters, all on a copy of the state committed only when "
             "every result is finite. The FMU's `doStep` adds the gathering of the scalar inputs "
             "and the refresh of the outputs with the core's report (physical test and "
             "projection, identified flags). Targets of issue #6: core <= 50 us (spatial), FMU "
             "`doStep` <= 150 us; issue #26: native `doStep` <= 20 us (spatial).\n")
    L.append("\n### One-step RLS against a batch re-solve\n")
    L.append("The batch alternative re-solves over all N samples at every new sample: stack the "
             "rows, `lstsq` for mu, then `lstsq` for theta with the right-hand side "
             "y + psi D(mu) (spatial, momentum form, rows precomputed, so this is the solve "
             "alone; wall time, best of 5, as `lstsq` may use BLAS threads). The one-step modified RLS costs the same at every N.\n")
    ours = est_cost["spatial"]["core_momentum"]
    rows = [(N, fmt(t / 1e3, 2), fmt(ours / 1e3, 3), fmt(t / ours, 0)) for N, t in batch.items()]
    L.append(table(["N samples", "batch re-solve [ms]", "one-step RLS update incl. equations "
                    "[ms]", "batch / ours"], rows))

    # 3
    L.append("\n## 3. Accuracy\n")
    L.append("Core-level runs (Plant + Identifier, outputs fed every 0.1 s; one plant run feeds "
             "every estimator variant), 60 s. Relative error = |estimate - truth| / |truth|, or "
             "for a zero truth relative to 1 m (CoM) or to the body's largest principal moment "
             "(inertia). Transit = time after which the error stays below 0.1 % (inf: not "
             "within 0.1 % at the end: never). The planar model identifies 8 parameters (x, y "
             "translation and z rotation); the others stay at their guesses.\n")
    main_labs = [lab for lab, _, solver, _ in VARIANTS if solver == "paper"]
    for r, a in acc.items():
        sc = scenario(r)
        L.append(f"### {r} ({sc.name})\n")
        L.append(accuracy_table(r, a, main_labs, values=(r == "planar")))
        rows = []
        for lab in a["variants"]:
            v = a["variants"][lab]
            idx = a["idx"]
            tr = v["transit"][idx]
            rows.append((lab, f"{np.max(v['err20'][idx]) * 100:.3f}",
                         f"{np.max(v['err60'][idx]) * 100:.3f}",
                         "never" if not np.all(np.isfinite(tr)) else fmt(np.max(tr), 1)))
        L.append("\nSummary over the identified parameters, all variants (joint RLS = one RLS over "
                 "the 20 standard parameters instead of the paper's modified RLS):\n")
        L.append(table(["variant", "max error at 20 s [%]", "max error at 60 s [%]",
                        "last transit to 0.1 % [s]"], rows) + "\n")
        joint = [lab for lab in a["variants"] if lab not in main_labs]
        L.append("<details><summary>Per-parameter table of the joint-RLS variants</summary>\n")
        L.append(accuracy_table(r, a, joint, values=(r == "planar")))
        L.append("\n</details>\n")
    L.append("Paper (planar, medium target): all estimates within 0.1 % in under 20 s with the "
             "momentum method; the force method (accelerations by differencing) ends 0.67 % off "
             "on the target inertia (10.34 vs 10.41 kg.m2).\n")

    # 4
    L.append("## 4. Memory\n")
    if mem is None:
        L.append("Skipped (`--memory-seconds 0`).\n")
    else:
        L.append("Spatial co-simulation (plant + estimator FMUs through fmpy, 0.1 s step, the "
                 "20 estimates read every step) in a fresh subprocess; resident set size "
                 "(psutil) and peak RSS (`getrusage`) at simulated times.\n")
        rows = [(fmt(m["t"], 0), fmt(m["rss_MB"]), fmt(m["maxrss_MB"]),
                 fmt(m.get("wall_s", 0.0), 0)) for m in mem]
        L.append(table(["simulated time [s]", "RSS [MB]", "peak RSS [MB]", "wall [s]"], rows))
        if len(mem) >= 3:
            base = [m for m in mem if m["t"] >= 60.0]
            if len(base) >= 2:
                g = base[-1]["rss_MB"] - base[0]["rss_MB"]
                L.append(f"\nRSS growth from {base[0]['t']:.0f} s to {base[-1]['t']:.0f} s: "
                         f"{g:+.1f} MB.\n")

    # 5
    L.append("## 5. Studies with their own scripts\n")
    L.append("Not run by `run.py` (each takes minutes on Dask); their reports, tables and plots:\n")
    L.append("- random real targets, noise-free, excitation loop closed and off "
             "(`benchmarks/montecarlo.py`, issue 12): [MONTECARLO.md](MONTECARLO.md);\n"
             "- identification under realistic sensor noise (`benchmarks/noise.py`, issue 14): "
             "[NOISE.md](NOISE.md), discussed in "
             "[docs/identification.md](../docs/identification.md#6-under-noise);\n"
             "- a base that uses propellant, tracked with forgetting (`benchmarks/depletion.py`, "
             "issue 17): [DEPLETION.md](DEPLETION.md).\n")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    sys.exit(main())
