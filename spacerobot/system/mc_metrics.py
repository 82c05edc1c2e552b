"""Metrics of one identification run, from its recorded time series (Monte Carlo study).

Pure functions of arrays: no FMI, no Dask. The study (:mod:`.montecarlo`) records, per
communication point, the 20 reported estimates, the estimator's flags and the plant's
excitation level, and reduces them with :func:`run_metrics` to one row of the results table.
"""
from __future__ import annotations

import math
from typing import Dict, Sequence

import numpy as np

__all__ = ["settle_time", "rise_time", "run_metrics"]


def settle_time(time: np.ndarray, err: np.ndarray, tol: float) -> float:
    """First time from which ``err`` stays below ``tol`` to the end; NaN if it ends above.

    Parameters
    ----------
    time : (N,) communication points [s];  err : (N,) error at each point;  tol : threshold.
    """
    above = np.flatnonzero(~(np.asarray(err) < tol))       # NaN counts as above
    if len(above) == 0:
        return float(time[0])
    k = above[-1] + 1
    return float(time[k]) if k < len(time) else math.nan


def rise_time(time: np.ndarray, flag: np.ndarray) -> float:
    """First time ``flag`` is 1 (NaN if never)."""
    on = np.flatnonzero(np.asarray(flag) > 0.5)
    return float(time[on[0]]) if len(on) else math.nan


def run_metrics(time: np.ndarray, est: np.ndarray, truth: np.ndarray, scale: np.ndarray,
                identified: np.ndarray, physical: np.ndarray, excite: np.ndarray,
                bodies: Dict[str, Sequence[int]]) -> Dict[str, float]:
    """Reduce one run to the columns of the Monte Carlo table.

    Parameters
    ----------
    time : (N,) communication points [s]
    est : (N, 20) reported estimates (order of ``interface.ESTIMATE_NAMES``)
    truth : (20,) true parameters;  scale : (20,) error scale (``interface.error_scale``)
    identified : (N, 2) the estimator's ``diag.identified.base``, ``diag.identified.target``
    physical : (N,) bool, whether every reported body was physical at each point
    excite : (N,) the plant's excitation input ``ident.excite``
    bodies : ``{'base': indices, 'target': indices}`` of the IDENTIFIED estimates of each body

    Returns
    -------
    dict with ``worst_error`` (at the end, over the identified estimates; the error of an
    estimate is ``|est - truth| / scale``, the ``error/scale`` of every table), ``worst_param``
    index, ``t_1pct`` and ``t_01pct`` (settling times of the worst error), per body
    ``identified.<b>`` (final flag), ``t_identified.<b>`` (first rise),
    ``false_identified.<b>`` (1 if the flag was ever 1 while an estimate of that body was
    more than 1 % off), ``physical`` (1 if every reported estimate was physical), ``excite_mean``
    and ``t_excite_off`` (last time the requested level was above 0; NaN if it never was).
    """
    rel = np.abs(np.asarray(est) - truth) / scale                       # (N, 20)
    ids = sorted(i for ix in bodies.values() for i in ix)
    worst = rel[:, ids].max(axis=1)
    out: Dict[str, float] = {
        "worst_error": float(worst[-1]),
        "worst_param": int(ids[int(np.argmax(rel[-1, ids]))]),
        "t_1pct": settle_time(time, worst, 1e-2),
        "t_01pct": settle_time(time, worst, 1e-3),
    }
    for k, (who, ix) in enumerate(bodies.items()):
        flag = np.asarray(identified)[:, k]
        body_worst = rel[:, list(ix)].max(axis=1)
        out[f"identified.{who}"] = int(flag[-1] > 0.5)
        out[f"t_identified.{who}"] = rise_time(time, flag)
        out[f"false_identified.{who}"] = int(np.any((flag > 0.5) & ~(body_worst <= 1e-2)))
    out["physical"] = int(np.all(physical))
    ex = np.asarray(excite, dtype=float)
    out["excite_mean"] = float(ex.mean())
    on = np.flatnonzero(ex > 0.0)
    out["t_excite_off"] = float(time[on[-1]]) if len(on) else math.nan
    return out
