"""Plots of run results: the paper's Fig. 4/5 view (estimate / truth against time), with the
+-2 standard deviation band the estimator reports around each estimate.

Reads the CSV written by :func:`spacerobot.system.runner.run_ssp` (columns ``time``,
``plant.<name>``, ``estimator.<name>``, ``estimator.sd.<name>``) or by ``spacerobot identify``
(columns ``time``, ``<name>``, ``sd.<name>`` and, where its telemetry had a truth,
``truth.<name>``). The truth of each parameter is the plant's parameter connector of the same
name (``plant.target.m`` ...), recorded by the runner, or, where the plant outputs one, its
current truth ``plant.truth.<name>`` at every sample (a base that uses propellant),
or the ``truth.<name>`` column that ``spacerobot identify`` copies from the telemetry.

The y-axis of each panel follows the estimate (its second half, where it has settled), never
the +-2 sd band: at the first samples the standard deviations are those of the prior, orders
of magnitude wider than the parameter, and would flatten every curve.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import interface
from ..interface import ESTIMATE_NAMES
from .recorder import read_csv

#: the paper's accuracy band (relative)
BAND = 1e-3
#: the uncertainty band drawn around each estimate: +- SD_BAND standard deviations
SD_BAND = 2.0


def estimate_prefix(data: Dict[str, np.ndarray]) -> str:
    """``'estimator.'`` for a run CSV, ``''`` for the output of ``spacerobot identify``."""
    return "estimator." if any(k.startswith("estimator.") for k in data) else ""


def sd_band(data: Dict[str, np.ndarray], name: str, prefix: str = "estimator."
            ) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """``(estimate - 2 sd, estimate + 2 sd)`` of estimate ``name`` at every sample; None if
    the CSV has no standard deviation column ``<prefix>sd.<name>``."""
    sd = data.get(f"{prefix}sd.{name}")
    if sd is None or sd.dtype.kind != "f":
        return None
    est = data[prefix + name]
    return est - SD_BAND * sd, est + SD_BAND * sd


def identified(data: Dict[str, np.ndarray], prefix: str = "estimator.") -> List[str]:
    """Estimate names whose estimate ends elsewhere than it started (the identified parameters).

    The planar model identifies only ``m``, ``b[1]``, ``b[2]``, ``Izz`` of each body; the other
    estimates end at their initial guess (a physical projection may move them for a while on
    the way, as it did the out-of-plane moments) and are left out.
    """
    out = []
    for n in ESTIMATE_NAMES:
        col = data.get(prefix + n)
        if col is not None and col.dtype.kind == "f" and len(col) and col[-1] != col[0]:
            out.append(n)
    return out


def _truth_column(data: Dict[str, np.ndarray], name: str) -> Optional[np.ndarray]:
    """The truth of ``name`` against time: the plant's current truth ``plant.truth.<name>``,
    the ``truth.<name>`` column of ``spacerobot identify``'s output, or the plant's parameter
    ``plant.<name>``, the first recorded."""
    for prefix in ("plant.truth.", "truth.", "plant."):
        col = data.get(prefix + name)
        if col is not None and col.dtype.kind == "f" and len(col):
            return col
    return None


def _truth(data: Dict[str, np.ndarray], name: str) -> Optional[float]:
    """The truth of ``name`` at the end (:func:`_truth_column`), if recorded."""
    col = _truth_column(data, name)
    return None if col is None else float(col[-1])


def _truth_now(data: Dict[str, np.ndarray], name: str) -> Optional[np.ndarray]:
    """The truth of ``name`` against time where it changes during the run (a base that uses
    propellant), else None (a constant truth: :func:`_truth`)."""
    col = _truth_column(data, name)
    if col is None or not np.isfinite(col).all() or np.ptp(col) == 0.0:
        return None
    return col


def _limits(y: np.ndarray, centre: float, floor: float) -> Tuple[float, float]:
    """y-limits around ``centre`` that hold the finite values of ``y`` (the estimate's second
    half) with a margin, at least +-``floor``."""
    y = y[np.isfinite(y)]
    d = float(np.max(np.abs(y - centre))) if len(y) else 0.0
    d = max(1.3 * d, floor)
    return centre - d, centre + d


def _zero_truth_scale(data: Dict[str, np.ndarray], name: str) -> Tuple[float, str]:
    """Scale for the band of a zero-truth parameter, as in :func:`interface.error_scale`:
    ``COM_SCALE_MIN`` for a centre-of-mass component, the body's largest principal moment
    (diagonal truth) for an inertia element."""
    body, par = name.split(".", 1)
    if par.startswith("b["):
        return interface.COM_SCALE_MIN, f"{interface.COM_SCALE_MIN:g} m"
    diag = [_truth(data, f"{body}.{d}") for d in ("Ixx", "Iyy", "Izz")]
    diag = [abs(x) for x in diag if x is not None]
    scale = max(diag) if diag else 1.0
    return scale, f"{scale:g} kg.m2"


def _grid(n: int) -> Tuple[int, int]:
    cols = min(4, max(1, n))
    return int(math.ceil(n / cols)), cols


def plot_run(csv_path: str | Path, out: Optional[str | Path] = None,
             title: Optional[str] = None) -> Path:
    """Plot estimate / truth against time for every identified parameter, with the +-0.1 % band
    and the +-2 sd band the estimator reports around the estimate (:func:`sd_band`).

    Parameters whose truth is zero (a centre-of-mass component, a product of inertia) are
    plotted as the absolute error ``estimate - truth`` instead; their panel title says so.

    Parameters
    ----------
    csv_path : path
        CSV of a run (:func:`spacerobot.system.runner.run_ssp`).
    out : path, optional
        PNG to write (default: the CSV path with suffix ``.png``).
    title : str, optional
        Figure title (default: the CSV file name).

    Returns
    -------
    Path of the PNG.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    csv_path = Path(csv_path)
    data = read_csv(csv_path)
    if "time" not in data:
        raise ValueError(f"{csv_path}: no 'time' column; not a run CSV")
    prefix = estimate_prefix(data)
    names = identified(data, prefix)
    if not names:
        raise ValueError(f"{csv_path}: no {prefix}<parameter> column changes over time; "
                         f"nothing to plot (is this a run CSV with at least two samples?)")
    t = data["time"]
    rows, cols = _grid(len(names))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.7 * rows), squeeze=False,
                             sharex=True)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    half = slice(len(t) // 2, None)
    band_drawn = False
    for ax, n in zip(axes.flat, names):
        est = data[prefix + n]
        now = _truth_now(data, n)
        truth = _truth(data, n) if now is None else float(now[-1])
        ref = truth if now is None else now           # a truth that changes: sample by sample
        band = sd_band(data, n, prefix)
        if band is not None:
            # the +-2 sd band in the panel's units: estimate, error (truth 0), estimate / truth
            lo, hi = (band if truth is None else (band[0] - ref, band[1] - ref) if truth == 0.0
                      else (band[0] / ref, band[1] / ref))
            ok = np.isfinite(lo) & np.isfinite(hi)
            ax.fill_between(t, np.minimum(lo, hi), np.maximum(lo, hi), where=ok,
                            color="tab:blue", alpha=0.2, lw=0, label="±2 sd")
            band_drawn = True
        if truth is None:
            ax.plot(t, est, lw=1.2)
            ax.set_title(f"{n} (no truth in CSV)", fontsize=9)
            ax.set_ylabel("estimate")
            end = float(est[-1]) if np.isfinite(est[-1]) else 0.0
            ax.set_ylim(*_limits(est[half], end, max(5 * BAND * abs(end), 1e-9)))
        elif truth == 0.0:
            err = est - ref
            ax.plot(t, err, lw=1.2)
            ax.axhline(0.0, color="k", lw=0.6)
            scale, scale_txt = _zero_truth_scale(data, n)
            ax.axhspan(-BAND * scale, BAND * scale, color="tab:green", alpha=0.25, lw=0)
            ax.set_title(f"{n}: absolute error (truth = 0)\nband ±0.1 % of {scale_txt}",
                         fontsize=8)
            ax.set_ylabel("estimate - truth")
            ax.set_ylim(*_limits(err[half], 0.0, 5 * BAND * scale))
        else:
            ratio = est / ref
            ax.plot(t, ratio, lw=1.2)
            ax.axhspan(1 - BAND, 1 + BAND, color="tab:green", alpha=0.25, lw=0,
                       label="±0.1 %")
            ax.axhline(1.0, color="k", lw=0.6)
            d = float(np.max(np.abs(ratio[half] - 1.0))) if len(ratio[half]) else 0.5
            d = min(0.5, max(5 * BAND, 1.3 * d))
            ax.set_ylim(1 - d, 1 + d)
            ax.set_title(f"{n} / truth ({truth:g})" if now is None else
                         f"{n} / current truth ({truth:g} at the end)", fontsize=9)
            ax.set_ylabel("estimate / truth")
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    for ax in axes.flat[:len(names)]:
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper right")
            break
    fig.suptitle(title or f"{csv_path.name}: estimates against the truth "
                          f"(green: ±0.1 %" + ("; blue: ±2 reported sd)" if band_drawn else ")"),
                 fontsize=11)
    fig.tight_layout()
    out = Path(out) if out is not None else csv_path.with_suffix(".png")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_csv(csv_path: str | Path, out: Optional[str | Path] = None) -> Path:
    """Plot a run CSV, or a sweep table (a CSV with a ``sweep_id`` column) through
    :func:`spacerobot.system.sweep.plot_sweep`."""
    import csv as _csv

    with open(csv_path, newline="") as f:
        header = next(_csv.reader(f), [])
    if "sweep_id" in header:
        from . import sweep
        out = out if out is not None else Path(csv_path).with_suffix(".png")
        return Path(sweep.plot_sweep(csv_path, out))
    return plot_run(csv_path, out)
