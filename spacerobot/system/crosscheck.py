"""FMI cross-check artifacts for the two FMUs of a robot.

For each FMU this writes, following the FMI Cross-Check rules (version 4.1, section 9.1.4 and
Appendix B "CSV rules"; https://github.com/modelica/fmi-cross-check), into

    <out>/fmus/2.0/cs/<platform>/spacerobot/<version>/<Model>/

- ``<Model>.fmu``        the FMU as built for the scenario;
- ``<Model>_ref.opt``    ``StartTime``, ``StopTime``, ``StepSize`` (the fixed communication step),
                         ``RelTol``, plus the optional ``OutputIntervalLength``;
- ``<Model>_ref.csv``    the reference result (time + at most 10 important outputs, as the rules
                         recommend), computed by the project's co-simulation loop (:func:`.runner.simulate`);
- ``<Model>_in.csv``     the input signals (estimator only: the plant has no inputs). They are the
                         plant outputs sampled at every communication point, i.e. exactly what the
                         estimator receives when wired to the plant;
- ``ReadMe.md``          how the files were made and how to re-simulate them.

Each FMU runs with its default start values (a cross-check importer sets nothing), so the
scenario - robot and target - is the one the FMU was built for.

Reading the CSVs: the first line holds the variable names quoted with double quotes (CSV rules).
Several estimator inputs are FMI structured names with a comma (``base.A[1,2]``). A CSV reader
that honours the quotes (Python's :mod:`csv`, :func:`read_crosscheck_csv`) reads them correctly;
fmpy 0.3.32's ``fmpy.util.read_csv`` and ``numpy.genfromtxt`` split the header at every comma and
mislabel the columns, so do not feed ``_in.csv`` to ``fmpy simulate --input-file``; use
:func:`read_crosscheck_csv` and pass the array to ``fmpy.simulate_fmu(input=...)``.
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
from .reader import system_of_fmus
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
}

MODELS = {"plant": "SpaceRobotPlant", "estimator": "SpaceRobotEstimator"}


# -- the reference run: the project's one co-simulation loop ---------------------------------------
#: the estimator parameter that keeps the excitation loop open in the references
OPEN_LOOP = ("ident.excite_mode", int(ExciteMode.OFF))


def reference_run(plant_fmu: Path, estimator_fmu: Path, stop_time: float, step: float) -> dict:
    """Run plant -> estimator with default start values (the estimator's excitation request
    off, :data:`OPEN_LOOP`) at a fixed communication step.

    The system of the two FMU files wired name to name (:func:`.reader.system_of_fmus`) run by
    :func:`.runner.simulate`: at every communication point t_k the estimator's inputs are set
    to the plant's outputs at t_k, then both FMUs step to t_{k+1} = (k + 1) * step (the time grid
    fmpy's ``simulate_fmu`` uses). Returns ``{"time", "plant_names", "plant", "inputs_names",
    "inputs", "est_names", "est"}`` with one row per communication point, t = 0 included.
    """
    from fmpy import read_model_description

    _n_steps(stop_time, step)
    fmus = {"plant": Path(plant_fmu), "estimator": Path(estimator_fmu)}
    variables = {k: read_model_description(str(p)).modelVariables for k, p in fmus.items()}
    names = {k: [v.name for v in vs if v.causality == c]
             for k, c, vs in (("plant", "output", variables["plant"]),
                              ("inputs", "input", variables["estimator"]),
                              ("est", "output", variables["estimator"]))}
    missing = [x for x in names["inputs"] if x not in names["plant"]]
    if missing:
        raise ValueError(f"plant has no outputs for estimator inputs {missing}")
    # the paper's open loop: the estimator asks for no excitation, so the plant's input
    # ident.excite stays at its start value 0 and the plant alone reproduces its reference
    res = simulate(system_of_fmus(fmus, step, stop_time), ".", progress=False,
                   overrides={f"estimator.{OPEN_LOOP[0]}": OPEN_LOOP[1]})

    def table(comp: str, cols) -> np.ndarray:
        return np.column_stack([res.data[f"{comp}.{n}"].astype(float) for n in cols])
    return {"time": res.time, "plant_names": names["plant"], "plant": table("plant", names["plant"]),
            "inputs_names": names["inputs"], "inputs": table("estimator", names["inputs"]),
            "est_names": names["est"], "est": table("estimator", names["est"])}


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
    """Write the cross-check folders of both FMUs of ``robot``; returns ``{kind: folder}``.

    ``fmus`` = ``{"plant": path, "estimator": path}`` uses FMUs already built (they must have
    been built for the scenario wanted); otherwise they are built for ``scenario(robot, target)``.
    ``ref_variables`` overrides the outputs written to ``_ref.csv`` per kind.
    """
    from fmpy import platform

    out = Path(out)
    if fmus is None:
        from ..fmi.build import build_fmu
        from ..robots import scenario

        sc = scenario(robot, target)
        stage = out / "_build" / robot
        fmus = {k: build_fmu(k, sc, stage) for k in MODELS}
    ref = reference_run(fmus["plant"], fmus["estimator"], stop_time, step)
    folders = {}
    for kind, model in MODELS.items():
        folder = out / "fmus" / "2.0" / "cs" / platform / TOOL_NAME / __version__ / model
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copy2(fmus[kind], folder / f"{model}.fmu")
        names = (ref_variables or {}).get(kind) or REF_VARIABLES[(kind, robot)]
        all_names = ref["plant_names"] if kind == "plant" else ref["est_names"]
        unknown = [x for x in names if x not in all_names]
        if unknown:
            raise ValueError(f"{model} has no outputs {unknown}")
        data = ref[kind if kind == "plant" else "est"][:, [all_names.index(x) for x in names]]
        write_crosscheck_csv(folder / f"{model}_ref.csv", ref["time"], names, data)
        if kind == "estimator":
            write_crosscheck_csv(folder / f"{model}_in.csv", ref["time"], ref["inputs_names"],
                                 ref["inputs"])
        (folder / f"{model}_ref.opt").write_text(
            f"StartTime, 0.0\nStopTime, {stop_time!r}\nStepSize, {step!r}\nRelTol, {rel_tol!r}\n"
            f"OutputIntervalLength, {step!r}\n")
        (folder / "ReadMe.md").write_text(_readme(model, robot, stop_time, step, kind))
        folders[kind] = folder
    shutil.rmtree(out / "_build", ignore_errors=True)
    return folders


def _readme(model: str, robot: str, stop_time: float, step: float, kind: str) -> str:
    inputs = ("\nThe inputs in `{m}_in.csv` are the outputs of SpaceRobotPlant (same robot, "
              "default parameters) at every communication point; apply them at the communication "
              "point (they are sampled, the FMU does not interpolate). Several names contain a "
              "comma (`base.A[1,2]`): read the file with a CSV reader that honours quotes.\n"
              ).format(m=model) if kind == "estimator" else ""
    return (f"# {model} ({robot} robot), FMI 2.0 co-simulation, native C core\n\n"
            f"Reference computed by spacerobot {__version__} (`spacerobot crosscheck`): fixed "
            f"communication step {step} s from 0 to {stop_time} s, default start values "
            f"except the estimator's {OPEN_LOOP[0]} = {OPEN_LOOP[1]} (no excitation request, "
            f"so the plant's input ident.excite stays 0), plant -> estimator wired name to "
            f"name.\n{inputs}\n"
            "Any FMI host loads the FMU without set-up: its binaries (linux64, and win64 where "
            "the package was installed with the mingw cross-compiler) need nothing but the C "
            "runtime: see docs/fmus.md of the spacerobot project.\n")


# -- command line ------------------------------------------------------------------------------------
def register(subparsers) -> None:
    """Add ``spacerobot crosscheck --robot R --out DIR`` to an argparse subparsers object."""
    p = subparsers.add_parser(
        "crosscheck", help="write FMI cross-check files (_in.csv, _ref.csv, _ref.opt) for both FMUs",
        description="Build both FMUs of a robot and write, per FMU, the FMI cross-check files "
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
