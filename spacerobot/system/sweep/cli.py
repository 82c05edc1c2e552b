"""The ``spacerobot sweep`` command: options, TOML configuration, and the run."""
from __future__ import annotations

import argparse
import json
import sys
from typing import List, Optional, Sequence, Tuple

from ..bindings import parse_assignments
from ..cli import fail_on_errors
from .execute import run_sweep
from .plot import plot_sweep
from .points import make_points
from .table import SweepLocked, read_table

def parse_v0(text: str) -> List[Tuple[float, ...]]:
    """``"0,10;50,50;200,200"`` -> ``[(0, 10), (50, 50), (200, 200)]``."""
    out = []
    for part in text.split(";"):
        part = part.strip()
        if not part:
            continue
        try:
            v = tuple(float(x) for x in part.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"bad velocity {part!r} in {text!r}; expected "
                                             f"'vx,vy[,vz];vx,vy[,vz];...'") from None
        if len(v) not in (2, 3):
            raise argparse.ArgumentTypeError(f"velocity {part!r} must have 2 or 3 components")
        out.append(v)
    if not out:
        raise argparse.ArgumentTypeError("no velocity given")
    return out


def _csv_list(conv=str):
    def parse(text: str):
        try:
            return [conv(x.strip()) for x in text.split(",") if x.strip()]
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return parse


#: config/CLI key -> default
DEFAULTS = {"robot": ["planar"], "target": None, "method": ["momentum", "force"],
            "accel": ["measured"], "v0": None, "F_max": None, "stop_time": None,
            "workers": 2, "scheduler": None, "out": None, "overrides": {}, "build_dir": None,
            "plot": None}


def load_config(path) -> dict:
    """Read a sweep TOML file (keys as :data:`DEFAULTS`; ``F-max``/``stop-time`` also accepted)."""
    import tomllib

    with open(path, "rb") as f:
        cfg = tomllib.load(f)
    cfg = cfg.get("sweep", cfg)
    out = {}
    for k, v in cfg.items():
        key = k.replace("-", "_")
        if key == "accel_source":
            key = "accel"
        if key not in DEFAULTS:
            raise ValueError(f"{path}: unknown key {k!r}; known keys: {', '.join(DEFAULTS)}")
        out[key] = v
    if "v0" in out:
        v0 = out["v0"]
        if isinstance(v0, str):
            out["v0"] = parse_v0(v0)
        elif v0 and not isinstance(v0[0], (list, tuple)):
            out["v0"] = [v0]
    return out


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "sweep", help="parameter study on a Dask cluster (local by default), resumable CSV",
        description="Run the co-simulation over a grid of points (Cartesian product of the "
                    "lists given here or in --config) on a Dask cluster, appending one row per "
                    "point to a CSV table. Re-running with the same --out skips finished points.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=cli_sweep)
    return p


def add_arguments(p: argparse.ArgumentParser) -> None:
    S = argparse.SUPPRESS
    p.add_argument("--config", metavar="FILE.toml", help="TOML file with any of the options "
                   "below; options given on the command line take precedence")
    p.add_argument("--robot", type=_csv_list(), default=S, help="robot(s): planar,spatial or "
                   "URDF files (FILE.urdf, FILE.urdf#ee=LINK) (default planar)")
    p.add_argument("--target", type=_csv_list(), default=S,
                   help="target size(s): small,medium,large (default: the robot's default)")
    p.add_argument("--method", type=_csv_list(), default=S,
                   help="momentum,force (default both)")
    p.add_argument("--accel", type=_csv_list(), default=S,
                   help="acceleration source(s) of the force method: measured,differenced "
                        "(default measured)")
    p.add_argument("--v0", type=parse_v0, default=S,
                   help="initial base velocities 'vx,vy[,vz];...' [m/s] (default: the robot's scenario, planar '1,2')")
    p.add_argument("--F-max", dest="F_max", type=_csv_list(float), default=S,
                   help="thruster force bound(s) [N] (default: the scenario's, 10)")
    p.add_argument("--stop-time", dest="stop_time", type=_csv_list(float), default=S,
                   help="stop time(s) [s] (default: the scenario's, planar 30, spatial 60)")
    p.add_argument("--set", dest="overrides", action="append", default=S, metavar="NAME=VALUE",
                   help="extra FMI override for every point, e.g. plant.base.omega0[3]=0.2 "
                        "(repeatable)")
    p.add_argument("--workers", type=int, default=S, help="local cluster worker processes "
                   "(default 2)")
    p.add_argument("--scheduler", default=S, metavar="ADDRESS",
                   help="use an existing Dask scheduler (e.g. tcp://host:8786); its workers "
                        "need only this package installed (the .ssp is sent to them, no shared "
                        "file system)")
    p.add_argument("--build-dir", dest="build_dir", default=S,
                   help="where the .ssp is built on this machine (default <out>.build/)")
    p.add_argument("--out", default=S, help="results CSV (appended; resumed if it exists)")
    p.add_argument("--plot", default=S, metavar="PNG", help="also plot the table to PNG")
    p.add_argument("--dry-run", action="store_true", help="list the points and their ids")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _settings(args: argparse.Namespace) -> dict:
    cfg = dict(DEFAULTS)
    if getattr(args, "config", None):
        cfg.update(load_config(args.config))
    given = {k: v for k, v in vars(args).items() if k in DEFAULTS}
    if "overrides" in given:
        try:
            ov = parse_assignments(given["overrides"])
        except ValueError as e:
            raise SystemExit(f"spacerobot sweep: {e}") from None
        given["overrides"] = {**(cfg.get("overrides") or {}), **ov}
    cfg.update(given)
    if not cfg.get("out"):
        raise SystemExit("spacerobot sweep: --out CSV (or 'out' in the config) is required")
    return cfg


@fail_on_errors("sweep")
def cli_sweep(args: argparse.Namespace) -> int:
    """The ``spacerobot sweep`` command; returns the exit status (1 if a point failed)."""
    cfg = _settings(args)
    try:
        points = make_points(cfg["robot"], cfg["target"], cfg["method"], cfg["accel"], cfg["v0"],
                             cfg["F_max"], cfg["stop_time"], cfg["overrides"])
    except ValueError as e:
        raise SystemExit(f"spacerobot sweep: {e}")
    if getattr(args, "dry_run", False):
        for p in points:
            print(p.id, json.dumps(p.canonical(), sort_keys=True))
        return 0
    try:
        summary = run_sweep(points, cfg["out"], workers=cfg["workers"],
                            scheduler=cfg["scheduler"], build_dir=cfg["build_dir"],
                            progress=not getattr(args, "no_progress", False))
    except SweepLocked as e:
        print(f"spacerobot sweep: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        done = sum(r["status"] == "ok" for r in read_table(cfg["out"]))
        print(f"spacerobot sweep: interrupted; {cfg['out']} holds {done} finished point(s); "
              f"run the same command again to resume", file=sys.stderr)
        return 130
    print(summary)
    if cfg.get("plot"):
        print("plot:", plot_sweep(cfg["out"], cfg["plot"]))
    return 1 if summary.failed else 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m spacerobot.system.sweep ...`` (same options as ``spacerobot sweep``)."""
    parser = argparse.ArgumentParser(prog="spacerobot-sweep")
    add_arguments(parser)
    return cli_sweep(parser.parse_args(argv))

