"""The ``spacerobot`` command line. Every branch only calls the library.

::

    spacerobot build --robot planar|spatial|ROBOT.urdf [--ee LINK] [--motion M] [--out DIR]
                     [--sensors]
    spacerobot run [--robot planar|spatial|ROBOT.urdf [--ee LINK] | SSP_FILE] [--target NAME]
                   [--method momentum|force] [--accel measured|differenced]
                   [--solver paper|joint] [--stop-time T] [--out CSV] [--set NAME=VALUE ...]
                   [--sensors]
    spacerobot identify TELEMETRY.csv --robot planar|spatial|ROBOT.urdf [--method ...] [--out CSV]
    spacerobot plot CSV [--out PNG]
    spacerobot sweep ...        (spacerobot.system.sweep, if installed)
    spacerobot montecarlo ...   (spacerobot.system.montecarlo)
    spacerobot crosscheck ...   (spacerobot.system.crosscheck, if installed)
"""
from __future__ import annotations

import argparse
import functools
import hashlib
import importlib
import importlib.util
import os
import re
import sys
from pathlib import Path
from typing import Optional, Sequence

from .. import __version__
from ..interface import identified_estimates
from ..robots import (PAPER_PLANAR_MEDIUM, PARAMETER_SETS, ROBOTS, get_robot, robot_kind,
                      robot_label, robot_spec)
from .codes import ACCEL_CODES, METHOD_CODES, SOLVER_CODES, estimator_overrides


class CommandError(Exception):
    """A failure the command line reports in one line (exit status 1), without a traceback."""


def fail_on_errors(command: str):
    """Decorator of a sub-command: every expected failure becomes one line ``spacerobot
    <command>: error: ...`` on stderr and exit status 1; Ctrl-C exit status 130."""
    def wrap(func):
        @functools.wraps(func)
        def run(args) -> int:
            from .errors import SimulationError
            try:
                return func(args)
            except BrokenPipeError:
                raise                         # the reader went away: main() ends quietly
            except KeyboardInterrupt:
                print(f"spacerobot {command}: interrupted", file=sys.stderr)
                return 130
            except (CommandError, SimulationError, OSError, ValueError, KeyError) as e:
                msg = e.args[0] if isinstance(e, KeyError) and e.args else e
                if isinstance(e, OSError) and e.filename and str(e.filename) not in str(msg):
                    msg = f"{e.filename}: {e.strerror or msg}"
                print(f"spacerobot {command}: error: {msg}", file=sys.stderr)
                return 1
        return run
    return wrap


def notice(command: str, text: str) -> None:
    """One line ``spacerobot <command>: <text>`` on stderr, at once: what a slow step is about
    to do, or that a result file is replaced (stdout stays the result)."""
    print(f"spacerobot {command}: {text}", file=sys.stderr, flush=True)


#: the longest settings tag put into a default file name as NAME=VALUE pairs; longer: a hash
MAX_TAG = 60


def _value_text(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def settings_tag(assignments: Optional[Sequence[str]], stop_time: Optional[float] = None,
                 strip: str = "") -> str:
    """The part of a default result name that holds the settings a run was given beyond the
    named choices: the ``--set NAME=VALUE`` overrides (sorted by name, the prefix ``strip``
    removed from each name, characters other than letters, digits and ``._=-`` replaced by
    ``_``, values as numbers: ``plant.base.v0[1]=5`` -> ``plant.base.v0_1=5``) joined by
    ``_``, then ``t<T>`` for an explicit ``--stop-time``. A tag longer than :data:`MAX_TAG`
    characters becomes ``set-<10 hex digits>``, a hash of it (stable from run to run). Empty
    without such settings.

    ``ValueError`` for an assignment that is not NAME=VALUE (as ``--set`` reports it)."""
    from .bindings import parse_assignments
    values = {k.removeprefix(strip) if strip else k: v
              for k, v in parse_assignments(assignments).items()}
    parts = []
    for name in sorted(values):
        safe = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_")
        parts.append(f"{safe}={_value_text(values[name])}")
    if stop_time is not None:
        parts.append(f"t{_value_text(stop_time)}")
    tag = "_".join(parts)
    if len(tag) > MAX_TAG:
        tag = "set-" + hashlib.sha1(tag.encode()).hexdigest()[:10]
    return tag


def announce_replace(command: str, path: Path) -> None:
    """Say on stderr, before a run, that its result will replace the existing file ``path``
    (results are never replaced silently)."""
    if path.is_file():
        notice(command, f"{path} exists: this run replaces it")


# ----------------------------------------------------------------------------------------------
# the robot argument (build, run, montecarlo)
# ----------------------------------------------------------------------------------------------

ROBOT_HELP = (f"robot: {' or '.join(sorted(ROBOTS))} (aliases of the shipped URDF files) or a "
              f"URDF file")


def add_robot_arguments(p: argparse.ArgumentParser, required: bool = False,
                        default: Optional[str] = None) -> None:
    """``--robot NAME|FILE.urdf``, ``--ee LINK`` and ``--motion auto|planar|spatial``."""
    shown = issubclass(p.formatter_class, argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--robot", metavar="ROBOT", required=required, default=default,
                   help=ROBOT_HELP + (f" (default: {default})" if default and not shown else ""))
    p.add_argument("--ee", metavar="LINK", help="URDF: the end-effector link (grasp point E, "
                   "target frame T); default: the last link of the chain")
    p.add_argument("--motion", choices=("auto", "planar", "spatial"), default="auto",
                   help="URDF: planar model (8 parameters) if every joint axis is parallel to "
                        "the base z axis (auto, the default), or forced")


def robot_key(args) -> Optional[str]:
    """The robot key (:func:`spacerobot.robots.robot_spec`) of the parsed ``--robot``,
    ``--ee``, ``--motion``, checked (a bad URDF raises ``ValueError`` naming the element)."""
    if args.robot is None:
        if args.ee is not None or args.motion != "auto":
            raise CommandError("--ee and --motion need --robot ROBOT.urdf")
        return None
    key = robot_spec(args.robot, args.ee, args.motion)
    get_robot(key)
    return key


# ----------------------------------------------------------------------------------------------
# sub-commands
# ----------------------------------------------------------------------------------------------

@fail_on_errors("build")
def cmd_build(args) -> int:
    from .ssd import build_system, default_build_dir
    robot = robot_key(args)
    out = Path(args.out) if args.out else default_build_dir(robot, args.fmi_version)
    what = "FMI 3.0 FMUs" if args.fmi_version == 3 else "FMUs"
    notice("build", f"building the {what} and the SSP for {robot_label(robot)} into {out}/ ...")
    for key, path in build_system(robot, out, sensors=args.sensors,
                                  fmi_version=args.fmi_version).items():
        print(f"{key:<12} {path}")
    warn_missing_platforms(args.fmi_version)
    return 0


def add_fmi_version_argument(p: argparse.ArgumentParser, what: str) -> None:
    """``--fmi-version 2|3``."""
    p.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                   help=f"FMI version of the FMUs {what}: 2 (default) or 3 (the same variables; "
                        "default folder build/<robot>-fmi3/; docs/fmus.md)")


def warn_missing_platforms(fmi_version: int = 2) -> None:
    """One line on stderr for each platform the FMUs cannot carry on this install."""
    from ..fmi.native import MODELS, binaries, platforms
    for ident, *_ in MODELS.values():
        built = binaries(ident, fmi_version=fmi_version)
        missing = sorted(set(platforms(fmi_version)) - set(built))
        for plat in missing:
            print(f"spacerobot build: {ident}.fmu carries no {plat} binary: it was not compiled "
                  f"when the package was installed (win64 needs x86_64-w64-mingw32-gcc, Debian "
                  f"package gcc-mingw-w64-x86-64; install it and reinstall the package)",
                  file=sys.stderr)


def result_name(robot: Optional[str], ssp: Path, target: Optional[str], args) -> Path:
    """Default results CSV: ``results/<robot>[_sensors]-<target>-<method>-<accel>-<solver>
    [-<settings>].csv``, ``<settings>`` the ``--set`` overrides and an explicit ``--stop-time``
    (:func:`settings_tag`), so that runs that differ in any of them do not overwrite each
    other."""
    sensors = "_sensors" if robot and args.sensors else ""
    name = robot_label(robot) + sensors if robot else ssp.stem
    tag = settings_tag(args.set, args.stop_time)
    return Path("results") / (f"{name}-{target or 'bound'}-{args.method}-"
                              f"{args.accel}-{args.solver}" + (f"-{tag}" if tag else "") + ".csv")


def set_stop_time(robot: Optional[str], target: Optional[str]) -> Optional[float]:
    """The duration [s] parameter set ``target`` of ``robot`` is made for (the ``depletion``
    set's 300 s), or None (the SSD's default experiment) for another set, an unknown one or
    without a robot. An SSP has one default experiment for all its sets, so the command line
    applies a set's own duration; other tools take a stop time from their user."""
    if not (robot and target):
        return None
    ps = PARAMETER_SETS[robot_kind(robot)].get(target)
    return ps.stop_time if ps else None


def set_labels(robot: Optional[str], target: Optional[str], method: Optional[str],
               accel: Optional[str]) -> tuple:
    """``(method, accel)`` labels of a run: those given, else those parameter set ``target``
    binds (the ``realistic`` set: force, differenced, for its noise profile), else momentum
    and measured."""
    ps = PARAMETER_SETS[robot_kind(robot)].get(target) if robot and target else None
    bound = dict(ps.estimator) if ps else {}
    label = {table: {code: name for name, code in codes.items()}
             for table, codes in (("method", METHOD_CODES), ("accel_source", ACCEL_CODES))}
    return (method or label["method"].get(bound.get("method"), "momentum"),
            accel or label["accel_source"].get(bound.get("accel_source"), "measured"))


@fail_on_errors("run")
def cmd_run(args) -> int:
    from .bindings import parse_assignments
    from .recorder import check_writable
    from .runner import format_results, run_ssp
    from .ssd import default_parameter_set, ensure_ssp, has_sensors, robot_of

    if args.ssp and args.robot:
        raise CommandError("give either --robot or SSP_FILE, not both")
    if args.ssp and args.fmi_version != 2:
        raise CommandError("--fmi-version goes with --robot: an SSP_FILE's FMUs are of the "
                           "version it was built with")
    key = robot_key(args)
    if args.ssp:
        ssp = Path(args.ssp)
        if not ssp.exists():
            raise CommandError(f"{ssp} does not exist")
        robot = robot_of(ssp)
    else:
        robot = key or "planar"
        ssp = None
    # an .ssp file: the set its SSD binds (the realistic one with the sensors), as other tools
    args.sensors = has_sensors(ssp) if ssp is not None else args.sensors
    target = args.target or (default_parameter_set(robot, args.sensors) if robot else None)
    args.method, args.accel = set_labels(robot, target, args.method, args.accel)
    overrides = estimator_overrides(args.method, args.accel, args.solver)
    overrides.update(parse_assignments(args.set))
    csv_path = Path(args.out) if args.out else result_name(robot, ssp or Path(robot), target,
                                                             args)
    check_writable(csv_path)              # before the build and the run: results never lost
    if csv_path.suffix.lower() != ".csv":  # a typo must not overwrite e.g. README.md
        raise CommandError(f"--out {csv_path}: the result file must end in .csv")
    announce_replace("run", csv_path)
    if ssp is None:
        what = "FMI 3.0 FMUs" if args.fmi_version == 3 else "FMUs"
        ssp = ensure_ssp(robot, args.build_dir, sensors=args.sensors, on_build=lambda out: notice(
            "run", f"building the {what} and the SSP for {robot_label(robot)} into {out}/ ..."),
            fmi_version=args.fmi_version)
    stop_time = args.stop_time if args.stop_time is not None else set_stop_time(robot, target)
    res = run_ssp(ssp, parameter_set=args.target, stop_time=stop_time,
                  overrides=overrides, csv_path=csv_path,
                  progress=False if args.no_progress else None)
    # the paper's values only beside the paper's scenario (no plant parameter changed)
    changed = any(k.startswith("plant.") for k in parse_assignments(args.set))
    paper = (PAPER_PLANAR_MEDIUM.get(args.method)
             if robot == "planar" and target == "medium" and not changed else None)
    print(f"{ssp}: robot {robot_label(robot) if robot else '?'}, parameter set "
          f"{target or '(as bound)'}, method "
          f"{args.method}, solver {args.solver}, accelerations {args.accel}; "
          f"t = {res.start_time:g} .. {res.stop_time:g} s, step {res.step_size:g} s")
    print(format_results(res, paper, identified_estimates(get_robot(robot)) if robot else None))
    if paper:
        print("paper: Zhang, Yue, Yuan (2020), planar medium target, final estimates "
              f"({args.method}-based)")
    print(f"CSV: {res.csv_path}")
    return 0


@fail_on_errors("plot")
def cmd_plot(args) -> int:
    from .plot import plot_csv
    print(plot_csv(args.csv, args.out))
    return 0


# ----------------------------------------------------------------------------------------------
# parser
# ----------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    """The argument parser (with ``sweep``/``montecarlo``/``crosscheck``/``identify``/
    ``design-excitation`` if those modules are installed)."""
    parser = argparse.ArgumentParser(
        prog="spacerobot",
        description="Online identification of base and target inertial parameters of a space "
                    "robot after capture: FMUs, SSP system, co-simulation, plots.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("build", help="build the plant and estimator FMUs and the .ssp",
                       description="Build SpaceRobotPlant.fmu, SpaceRobotEstimator.fmu, "
                                   "SystemStructure.ssd, the parameter sets and <robot>.ssp.")
    add_robot_arguments(p, required=True)
    p.add_argument("--out", metavar="DIR", help="output folder (default build/<robot>/, "
                                                "<robot> the URDF's robot name)")
    p.add_argument("--sensors", action="store_true", help="the system with the sensors FMU "
                   "between plant and estimator (<robot>_sensors.ssp, docs/sensors.md)")
    add_fmi_version_argument(p, "built")
    p.set_defaults(func=cmd_build)

    p = sub.add_parser("run", help="run the co-simulation and print the final estimates",
                       description="Run the SSP system (built into build/<robot>/, or "
                                   "build/<robot>-fmi3/ for FMI 3.0, if needed) "
                                   "and print every estimate against the truth and, for the "
                                   "planar medium target, the paper's values.")
    p.add_argument("ssp", nargs="?", metavar="SSP_FILE", help="a .ssp archive (or folder) to "
                   "run instead of --robot")
    add_robot_arguments(p)
    p.add_argument("--target", help="parameter set: small|medium|large|paper|excited (planar "
                                    "robots), paper|default|depletion|wings|slosh|flexible "
                                    "(spatial robots); default: the one bound in the SSD")
    p.add_argument("--method", choices=list(METHOD_CODES),
                   help="identification equations (default: the parameter set's, e.g. force "
                        "for realistic sensors; else momentum)")
    p.add_argument("--accel", choices=list(ACCEL_CODES),
                   help="force method: measured accelerations or differenced velocities "
                        "(default: the parameter set's; else measured)")
    p.add_argument("--solver", choices=list(SOLVER_CODES), default="paper")
    p.add_argument("--stop-time", type=float, metavar="T",
                   help="stop time [s] (default: the parameter set's own duration, e.g. "
                        "300 s for depletion, else the SSD's DefaultExperiment)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="FMU parameter override, e.g. plant.base.v0[1]=5 (repeatable)")
    p.add_argument("--out", metavar="CSV",
                   help="results CSV (default results/<robot>-<target>-<method>-<accel>-"
                   "<solver>[-<settings>].csv, <settings> the --set overrides and an explicit "
                   "--stop-time; an existing file is replaced, with a note on stderr)")
    p.add_argument("--build-dir", metavar="DIR", help="where to build the .ssp for --robot "
                                                      "(default build/<robot>/, FMI 3.0: "
                                                      "build/<robot>-fmi3/)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--sensors", action="store_true", help="with --robot: run the system with "
                   "the sensors FMU (parameter sets ideal, realistic (default) and the "
                   "others; seed: --set sensors.seed=N)")
    add_fmi_version_argument(p, "built for --robot")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("plot", help="plot a run CSV (paper Fig. 4/5 view) or a sweep table",
                       description="Estimate / truth against time for the identified "
                                   "parameters with the +-0.1 %% band; a CSV with a sweep_id "
                                   "column is plotted by spacerobot.system.sweep.plot_sweep.")
    p.add_argument("csv", metavar="CSV")
    p.add_argument("--out", metavar="PNG", help="output PNG (default: CSV with .png suffix)")
    p.set_defaults(func=cmd_plot)

    for mod in ("sweep", "montecarlo", "crosscheck", "identify", "design"):
        name = f"{__package__}.{mod}"
        if importlib.util.find_spec(name) is not None:
            importlib.import_module(name).register(sub)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``spacerobot`` console script; returns the exit status.

    A reader that closes the pipe early (``spacerobot run ... | head -1``) ends the command
    quietly with status 141 (128 + SIGPIPE, what a Unix tool killed by the signal returns):
    no traceback, no error line; the results file of a run is written before its table is
    printed."""
    args = build_parser().parse_args(argv)
    try:
        status = int(args.func(args) or 0)
        sys.stdout.flush()                  # a closed pipe shows here, not at exit
        return status
    except BrokenPipeError:
        # Python would flush stdout again at exit and report the closed pipe: point stdout at
        # /dev/null first (the recipe of the Python documentation, signal module: SIGPIPE)
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141


if __name__ == "__main__":
    sys.exit(main())
