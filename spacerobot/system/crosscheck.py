"""FMI cross-check files for the three FMUs of a robot.

For each FMU this writes, following the FMI Cross-Check rules (version 4.1, section 9.1.4 and
Appendix B "CSV rules"; https://github.com/modelica/fmi-cross-check), into

    <out>/fmus/2.0/cs/<platform>/spacerobot/<version>/<Model>/

- ``<Model>.fmu``        the FMU as built for the scenario;
- ``<Model>_ref.opt``    ``StartTime``, ``StopTime``, ``StepSize`` (the fixed communication step),
                         ``RelTol``, plus the optional ``OutputIntervalLength``;
- ``<Model>_ref.csv``    the reference result (time + at most 10 important outputs, as the rules
                         recommend), computed by the project's co-simulation loop (:func:`.runner.simulate`);
- ``<Model>_in.csv``     the input signals (estimator and sensors: the plant has no inputs): the
                         plant's outputs at every communication point, i.e. what the FMU
                         receives when wired to the plant;
- ``ReadMe.md``          how the files were made and how to re-simulate them.

Each FMU runs with its default start values (a cross-check importer sets nothing), so the
scenario - robot and target - is the one the FMU was built for.

Names with a comma. The cross-check's own validator (fmpy's ``validate_test_fmu``, which the
cross-check repository runs) and importers that read the CSVs with ``numpy.genfromtxt`` or
fmpy's ``read_csv`` split a header at every comma, quoted or not, so a column ``"base.A[1,2]"``
cannot be read back. The rules ask for the FMU's own names, so these inputs (``base.A[i,j]``,
``true.base.A[i,j]``) are left out of ``_in.csv`` (:func:`csv_name_ok`): an importer keeps
them at their start values (the identity), and the reference is computed the same way (those
inputs not fed). The files then check an importer, not the estimates: with the base's
attitude held at the identity the estimator sees a base that does not turn.

The sensors have direct feedthrough; their reference is sampled as importers sample a
co-simulation FMU (:func:`sampled_after_each_step`).
"""
from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from .. import __version__
from ..interface import ExciteMode
from .cli import fail_on_errors
from .reader import wired_system
from .runner import simulate

TOOL_NAME = "spacerobot"
MAX_CSV_BYTES = 1_000_000          # cross-check rule: a CSV file must not be larger than 1 MB

#: at most 10 "important variables" per reference file (recommendation of the rules)
REF_VARIABLES = {
    ("plant", "planar"): ["base.r[1]", "base.r[2]", "base.v[1]", "base.v[2]", "base.omega[3]",
                          "arm.q[1]", "arm.q[2]", "thrust.F[1]", "thrust.M[3]", "system.L[3]"],
    ("plant", "spatial"): ["base.r[1]", "base.v[3]", "base.omega[1]", "base.omega[2]",
                           "base.omega[3]", "arm.q[1]", "arm.q[2]", "thrust.F[1]", "thrust.M[3]",
                           "system.L[1]"],
    # the planar model identifies m, b_x, b_y and Izz of each body
    ("estimator", "planar"): ["base.m", "base.b[1]", "base.b[2]", "base.Izz",
                              "target.m", "target.b[1]", "target.b[2]", "target.Izz"],
    ("estimator", "spatial"): ["base.m", "base.b[1]", "base.b[2]", "base.b[3]", "base.Izz",
                               "target.m", "target.b[1]", "target.b[2]", "target.b[3]",
                               "target.Izz"],
    ("sensors", "planar"): ["base.r[1]", "base.v[1]", "base.omega[3]", "base.a[1]", "arm.q[1]",
                            "arm.qd[1]", "thrust.F[1]", "thrust.M[3]", "thrust.J[1]",
                            "thrust.H[3]"],
    ("sensors", "spatial"): ["base.r[1]", "base.v[3]", "base.omega[1]", "base.a[2]", "arm.q[1]",
                             "arm.qd[2]", "thrust.F[1]", "thrust.M[3]", "thrust.J[1]",
                             "thrust.H[3]"],
}

MODELS = {"plant": "SpaceRobotPlant", "estimator": "SpaceRobotEstimator",
          "sensors": "SpaceRobotSensors"}
#: the FMUs with inputs, and the plant output each input is, by name
INPUT_OF = {"estimator": lambda name: name,
            "sensors": lambda name: name[len("true."):] if name.startswith("true.") else None}


def csv_name_ok(name: str) -> bool:
    """Whether a variable name can be a column of a cross-check CSV that the cross-check's
    validator (``numpy.genfromtxt``) reads back: no comma, quoted or not."""
    return "," not in name


# -- the reference run: the project's one co-simulation loop ---------------------------------------
#: the estimator parameter that keeps the excitation loop open in the references
OPEN_LOOP = ("ident.excite_mode", int(ExciteMode.OFF))


def reference_run(fmus: Dict[str, Path], stop_time: float, step: float) -> dict:
    """The references of the plant, the estimator and the sensors, each fed the plant's
    outputs, with default start values (the estimator's excitation request off,
    :data:`OPEN_LOOP`) at a fixed communication step.

    ``fmus``: ``{"plant": path, "estimator": path[, "sensors": path]}``. The inputs whose names
    cannot be CSV columns (:func:`csv_name_ok`) are not fed: they keep their start values, as in
    an importer that applies ``_in.csv``. Plant and estimator run in :func:`.runner.simulate`:
    at every communication point t_k the estimator's inputs are set to the plant's outputs at
    t_k, then both step to t_{k+1} = (k + 1) * step (the time grid fmpy's ``simulate_fmu``
    uses). The sensors (direct feedthrough) are then sampled as importers sample a
    co-simulation FMU (:func:`sampled_after_each_step`). Returns ``{"time", "outputs": {kind:
    (names, table)}, "inputs": {kind: (names, table)}}``, one row per communication point, t = 0
    included.
    """
    from fmpy import read_model_description

    _n_steps(stop_time, step)
    fmus = {k: Path(p) for k, p in fmus.items()}
    variables = {k: read_model_description(str(p)).modelVariables for k, p in fmus.items()}
    names = {k: {c: [v.name for v in vs if v.causality == c] for c in ("input", "output")}
             for k, vs in variables.items()}
    fed = {}
    for kind in fmus:
        if kind == "plant":
            continue
        for n in names[kind]["input"]:
            if INPUT_OF[kind](n) not in names["plant"]["output"]:
                raise ValueError(f"the plant has no output for the {kind} input {n}")
        fed[kind] = [n for n in names[kind]["input"] if csv_name_ok(n)]
    # the paper's open loop: the estimator asks for no excitation, so the plant's input
    # ident.excite stays at its start value 0 and the plant alone reproduces its reference
    system = {k: fmus[k] for k in ("plant", "estimator") if k in fmus}
    connections = [("plant", n, "estimator", n) for n in fed.get("estimator", [])]
    res = simulate(wired_system(system, connections, step, stop_time), ".", progress=False,
                   overrides={f"estimator.{OPEN_LOOP[0]}": OPEN_LOOP[1]} if "estimator"
                   in system else None)

    def table(comp: str, cols) -> np.ndarray:
        return np.column_stack([res.data[f"{comp}.{n}"].astype(float) for n in cols])
    out = {"time": res.time, "outputs": {k: (names[k]["output"], table(k, names[k]["output"]))
                                         for k in system}, "inputs": {}}
    for kind, cols in fed.items():
        plant_cols = [INPUT_OF[kind](n) for n in cols]
        out["inputs"][kind] = (cols, table("plant", plant_cols))
    if "sensors" in fmus:
        outs = names["sensors"]["output"]
        out["outputs"]["sensors"] = (outs, sampled_after_each_step(
            fmus["sensors"], *out["inputs"]["sensors"], outs, res.time))
    return out


def sampled_after_each_step(fmu: Path, inputs: Sequence[str], rows: np.ndarray,
                            outputs: Sequence[str], time: np.ndarray) -> np.ndarray:
    """The ``outputs`` of an FMU with direct feedthrough as importers sample a co-simulation FMU
    (fmpy's ``simulate_fmu``, fmusim, the FMU Compliance Checker): at t_0 after its inputs of
    t_0 are set in initialisation mode; at t_(k+1) right after the step from t_k, its inputs
    still those of t_k (``rows[k]``). One row per point of ``time``."""
    from .instance import FMUInstance

    inst = FMUInstance(fmu, "reference")
    try:
        inst.fmu.setupExperiment(startTime=float(time[0]))
        inst.fmu.enterInitializationMode()
        inst.set_many(inputs, rows[0])
        inst.fmu.exitInitializationMode()
        inst.initialized = True
        got = [list(inst.values(outputs).values())]
        for k in range(len(time) - 1):
            inst.set_many(inputs, rows[k])
            inst.fmu.doStep(float(time[k]), float(time[k + 1] - time[k]))
            got.append(list(inst.values(outputs).values()))
    finally:
        inst.close()
    return np.array(got, dtype=float)


def _n_steps(stop_time: float, step: float) -> int:
    if not (math.isfinite(stop_time) and math.isfinite(step) and step > 0 and stop_time > 0):
        raise ValueError(f"stop time and step must be finite and > 0, got {stop_time}, {step}")
    n = round(stop_time / step)
    if n < 1 or abs(n * step - stop_time) > 1e-9 * stop_time:
        raise ValueError(f"stop time {stop_time} s must be a whole number of steps of {step} s")
    return n


# -- CSV in the cross-check dialect --------------------------------------------------------------
def write_crosscheck_csv(path: Path, time: np.ndarray, names: Sequence[str],
                         data: np.ndarray) -> None:
    """First line: quoted names (``"time"`` first); then unquoted C float literals, no trailing
    separator; 17 significant digits so that every double round-trips exactly."""
    with open(path, "w", newline="") as f:
        f.write(",".join(f'"{n}"' for n in ["time", *names]) + "\n")
        for t, row in zip(time, data):
            f.write(",".join(repr(float(x)) for x in (t, *row)) + "\n")
    size = Path(path).stat().st_size
    if size > MAX_CSV_BYTES:
        raise ValueError(f"{path} is {size} bytes; the cross-check rules allow at most 1 MB: "
                         "shorten the stop time or lengthen the step")


def read_crosscheck_csv(path: Path) -> np.ndarray:
    """Read a cross-check CSV into a structured array (first field ``time``), honouring quoted
    names that contain commas (``"base.A[1,2]"``). Raises if time is not monotonic."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = rows[0]
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: duplicate column names")
    values = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float)
    if values.ndim != 2 or values.shape[1] != len(names):
        raise ValueError(f"{path}: {len(names)} names but rows of {values.shape[-1]} values")
    if np.any(np.diff(values[:, 0]) < 0):
        raise ValueError(f"{path}: time is not monotonically increasing")
    out = np.zeros(len(values), dtype=[(n, float) for n in names])
    for i, n in enumerate(names):
        out[n] = values[:, i]
    return out


def read_ref_opt(path: Path) -> Dict[str, float]:
    """The ``<Model>_ref.opt`` entries (fmpy.util.read_ref_opt_file also checks them)."""
    from fmpy.util import read_ref_opt_file

    return read_ref_opt_file(str(path))


# -- the artifacts -------------------------------------------------------------------------------
def write_crosscheck(robot: str = "planar", out: str | Path = "build/crosscheck",
                     target: Optional[str] = None, stop_time: float = 20.0, step: float = 0.1,
                     rel_tol: float = 1e-6, fmus: Optional[Dict[str, Path]] = None,
                     ref_variables: Optional[Dict[str, List[str]]] = None) -> Dict[str, Path]:
    """Write the cross-check folders of the three FMUs of ``robot``; returns ``{kind: folder}``.

    ``fmus`` = ``{"plant": path, "estimator": path, "sensors": path}`` uses FMUs already built
    (they must have been built for the scenario wanted); otherwise they are built for
    ``scenario(robot, target)``. ``ref_variables`` overrides the outputs written to
    ``_ref.csv`` per kind.
    """
    from fmpy import platform

    out = Path(out)
    if fmus is None:
        from ..fmi.build import build_fmu
        from ..robots import scenario

        sc = scenario(robot, target)
        stage = out / "_build" / robot
        fmus = {k: build_fmu(k, sc, stage) for k in MODELS}
    fmus = {k: Path(fmus[k]) for k in MODELS}
    ref = reference_run(fmus, stop_time, step)
    folders = {}
    for kind, model in MODELS.items():
        folder = out / "fmus" / "2.0" / "cs" / platform / TOOL_NAME / __version__ / model
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copy2(fmus[kind], folder / f"{model}.fmu")
        names = (ref_variables or {}).get(kind) or REF_VARIABLES[(kind, robot)]
        all_names, outputs = ref["outputs"][kind]
        unknown = [x for x in names if x not in all_names]
        if unknown:
            raise ValueError(f"{model} has no outputs {unknown}")
        data = outputs[:, [all_names.index(x) for x in names]]
        write_crosscheck_csv(folder / f"{model}_ref.csv", ref["time"], names, data)
        if kind in ref["inputs"]:
            write_crosscheck_csv(folder / f"{model}_in.csv", ref["time"], *ref["inputs"][kind])
        (folder / f"{model}_ref.opt").write_text(
            f"StartTime, 0.0\nStopTime, {stop_time!r}\nStepSize, {step!r}\nRelTol, {rel_tol!r}\n"
            f"OutputIntervalLength, {step!r}\n")
        (folder / "ReadMe.md").write_text(_readme(model, robot, stop_time, step, kind))
        folders[kind] = folder
    shutil.rmtree(out / "_build", ignore_errors=True)
    return folders


def _readme(model: str, robot: str, stop_time: float, step: float, kind: str) -> str:
    inputs = ("\nThe inputs in `{m}_in.csv` are the outputs of SpaceRobotPlant (same robot, "
              "default parameters) at every communication point{feed}; apply them at the "
              "communication point (they are sampled, the FMU does not interpolate). The "
              "inputs {a} are not in the file: their names carry a comma, which the "
              "cross-check's CSV reader splits; keep them at their start values (the identity "
              "matrix), as the reference does.{sampling}\n"
              ).format(sampling=" The outputs (direct feedthrough: they measure the inputs "
                       "set) are sampled as fmpy, fmusim and the FMU Compliance Checker sample "
                       "a co-simulation FMU: at 0 s after the inputs of 0 s are set, then right "
                       "after each step, its inputs still those the step started from."
                       if kind == "sensors" else "",m=model, feed=" (the sensors' input `true.<name>` is the plant's "
                       "output `<name>`)" if kind == "sensors" else "",
                       a="`true.base.A[i,j]`" if kind == "sensors" else "`base.A[i,j]`") \
        if kind in INPUT_OF else ""
    return (f"# {model} ({robot} robot), FMI 2.0 co-simulation, native C core\n\n"
            f"Reference computed by spacerobot {__version__} (`spacerobot crosscheck`): fixed "
            f"communication step {step} s from 0 to {stop_time} s, default start values "
            f"except the estimator's {OPEN_LOOP[0]} = {OPEN_LOOP[1]} (no excitation request, "
            f"so the plant's input ident.excite stays 0), the plant's outputs wired to the "
            f"estimator's and the sensors' inputs.\n{inputs}\n"
            "Any FMI host loads the FMU without set-up: its binaries (linux64, and win64 where "
            "the package was installed with the mingw cross-compiler) need nothing but the C "
            "runtime: see docs/fmus.md of the spacerobot project.\n")


# -- command line ------------------------------------------------------------------------------------
def register(subparsers) -> None:
    """Add ``spacerobot crosscheck --robot R --out DIR`` to an argparse subparsers object."""
    p = subparsers.add_parser(
        "crosscheck", help="write FMI cross-check files (_in.csv, _ref.csv, _ref.opt) for the FMUs",
        description="Build the three FMUs of a robot and write, per FMU, the FMI cross-check files "
                    "into DIR/fmus/2.0/cs/<platform>/spacerobot/<version>/<Model>/.")
    p.add_argument("--robot", choices=("planar", "spatial"), default="planar")
    p.add_argument("--target", default=None, help="target of the scenario (default: the robot's)")
    p.add_argument("--out", default="build/crosscheck", help="output directory")
    p.add_argument("--stop-time", type=float, default=20.0, help="[s] (default 20)")
    p.add_argument("--step", type=float, default=0.1, help="communication step [s] (default 0.1)")
    p.set_defaults(func=run_cli)


@fail_on_errors("crosscheck")
def run_cli(args) -> int:
    folders = write_crosscheck(args.robot, args.out, target=args.target,
                               stop_time=args.stop_time, step=args.step)
    for kind, folder in folders.items():
        for f in sorted(folder.iterdir()):
            print(f)
    return 0
