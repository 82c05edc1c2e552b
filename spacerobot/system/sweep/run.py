"""Running one sweep point (in a Dask worker): the co-simulation, and its row of the table."""
from __future__ import annotations

import importlib
import os
import socket
import time
import traceback
from typing import Dict

from ...interface import relative_errors_by_name as relative_errors
from .points import PARAMS, Point, expected_truth
from .table import DIAG

#: where a point's co-simulation and the .ssp build come from ("module:function")
DEFAULT_RUNNER = "spacerobot.system.runner:run_ssp"
DEFAULT_BUILDER = "spacerobot.system.ssd:build_system"


def _resolve(spec: str):
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


def _lookup(mapping, name: str, prefix: str):
    if mapping is None:
        return None
    for key in (name, f"{prefix}.{name}"):
        try:
            return float(mapping[key])
        except (KeyError, IndexError, TypeError, ValueError):
            continue
    return None


def run_point(point: Point, ssp_path: str, runner: str = DEFAULT_RUNNER) -> Dict[str, object]:
    """Run one point; never raises: a failure becomes a row with ``status = failed``."""
    row: Dict[str, object] = dict(point.columns())
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    t0 = time.perf_counter()
    try:
        run_ssp = _resolve(runner)
        res = run_ssp(str(ssp_path), stop_time=point.stop_time, overrides=point.fmi_overrides(),
                      progress=False)
        t = getattr(res, "time", None)
        t_end = float(t[-1]) if t is not None and len(t) else float("nan")
        row["t_end"] = t_end
        final = getattr(res, "final", None)
        est = {p: _lookup(final, p, "estimator") for p in PARAMS}
        missing = [p for p, x in est.items() if x is None]
        if missing:
            raise RuntimeError(f"run result has no final estimate of {', '.join(missing)}")
        truth = expected_truth(point)
        for p in PARAMS:
            x = _lookup(getattr(res, "truth", None), p, "plant")
            if x is not None:
                truth[p] = x
        data = getattr(res, "data", None) or {}
        for d in DIAG:
            x = _lookup(final, d, "estimator")
            if x is None and len(data.get(f"estimator.{d}", ())):
                x = float(data[f"estimator.{d}"][-1])
            row[d] = "" if x is None else (int(x) if float(x).is_integer() else x)
        rel = relative_errors(est, truth)
        for p in PARAMS:
            row[f"est.{p}"] = est[p]
            row[f"true.{p}"] = truth[p]
            row[f"relerr.{p}"] = rel[p]
        if not (t_end >= point.stop_time - 1e-6 * max(1.0, point.stop_time)):
            raise RuntimeError(f"co-simulation stopped at t = {t_end:g} s before the stop time "
                               f"{point.stop_time:g} s")
        row["status"], row["error"] = "ok", ""
    except Exception as e:  # noqa: BLE001 -- report every failure in the table
        row["status"] = "failed"
        msg = str(e).strip() or traceback.format_exc(limit=1).strip().splitlines()[-1]
        row["error"] = f"{type(e).__name__}: {msg}"
    row["wall_time"] = round(time.perf_counter() - t0, 3)
    return row
