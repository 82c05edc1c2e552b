"""Plot of a sweep table: relative error against |v0|, the paper's Figs. 6-9."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Dict, List

from ...robots import INERTIA_NAMES
from .points import IDENTIFIED, PARAMS
from .table import read_table

#: the paper's numbers quoted in the text (momentum-based I_n error at 60 s, F_max = 0.1 N)
PAPER_MOMENTUM_IN = ((math.hypot(0.0, 10.0), 0.066), (math.hypot(200.0, 200.0), 7.2))

_GROUPS = (("m", "mass", ("m",)), ("b", "centre of mass", ("b[1]", "b[2]", "b[3]")),
           ("I", "inertia", INERTIA_NAMES))


def _f(x: str) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def plot_sweep(csv_path, out_png=None, *, paper: bool = True):
    """Relative error of each final estimate against |v0| (log y), as the paper's Figs. 6-9.

    Panels: rows base / target, columns mass / centre of mass / inertia. One colour per series
    (method, acceleration source of the force method, and any other point parameter that
    varies in the table), one line style per component. Only ``status == ok`` rows and the
    parameters the robot identifies are drawn. With ``paper`` the two momentum-based I_n
    errors the paper quotes are marked. Returns the PNG path.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    csv_path = Path(csv_path)
    out_png = Path(out_png) if out_png else csv_path.with_suffix(".png")
    latest: Dict[str, Dict[str, str]] = {}
    for r in read_table(csv_path):
        latest[r["sweep_id"]] = r
    rows = [r for r in latest.values() if r["status"] == "ok"]
    if not rows:
        raise ValueError(f"{csv_path} has no successful sweep points to plot")
    varying = [c for c in ("robot", "target", "F_max", "stop_time", "overrides")
               if len({r[c] for r in rows}) > 1]

    def _short(c, v):
        if c == "overrides":
            ov = json.loads(v or "{}")
            return ", ".join(f"{k.split('.', 1)[-1]}={x:g}" for k, x in sorted(ov.items())) \
                or "no overrides"
        if c in ("F_max", "stop_time"):
            return f"{c}={_f(v):g}"
        return f"{c}={v}"

    def series(r):
        lab = r["method"] + (f" ({r['accel_source']} acc.)" if r["method"] == "force" else "")
        extra = ", ".join(_short(c, r[c]) for c in varying)
        return lab + (f", {extra}" if extra else "")

    groups: Dict[str, List[Dict[str, str]]] = {}
    for r in rows:
        groups.setdefault(series(r), []).append(r)
    identified = set()
    for r in rows:
        identified.update(IDENTIFIED.get(r["robot"], PARAMS))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ("-", "--", ":", "-.", (0, (5, 1)), (0, (1, 3)))
    markers = "osD^v<>p"
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), sharex=True)
    for i, who in enumerate(("base", "target")):
        for j, (_, title, comps) in enumerate(_GROUPS):
            ax = axes[i, j]
            shown = [c for c in comps if f"{who}.{c}" in identified]
            for s, (lab, rs) in enumerate(sorted(groups.items())):
                rs = sorted(rs, key=lambda r: (_f(r["v0_norm"]), r["sweep_id"]))
                x = np.array([_f(r["v0_norm"]) for r in rs])
                for k, comp in enumerate(shown):
                    y = 100.0 * np.array([_f(r[f"relerr.{who}.{comp}"]) for r in rs])
                    ax.plot(x, np.maximum(y, 1e-12), linestyle=styles[k % len(styles)],
                            marker=markers[s % len(markers)], color=colors[s % len(colors)],
                            ms=4)
            handles = [Line2D([], [], color="k", linestyle=styles[k % len(styles)], label=c)
                       for k, c in enumerate(shown)] if len(shown) > 1 else []
            if paper and who == "target" and title == "inertia":
                px, py = zip(*PAPER_MOMENTUM_IN)
                handles += ax.plot(px, py, "k*", ms=11, label="paper, momentum: I_n")
            if shown:
                ax.set_yscale("log")
            ax.set_title(f"{who}: {title}" + (f" ({shown[0]})" if len(shown) == 1 else ""))
            ax.grid(True, which="both", alpha=0.3)
            if i == 1:
                ax.set_xlabel("|v0| [m/s]")
            if j == 0:
                ax.set_ylabel("relative error [%]")
            if handles:
                ax.legend(handles=handles, fontsize=7, loc="best")
    series_handles = [Line2D([], [], color=colors[s % len(colors)], marker=markers[s % len(markers)],
                             label=lab) for s, lab in enumerate(sorted(groups))]
    ncol = min(len(series_handles), 3)
    fig.legend(handles=series_handles, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    info = {c: sorted({r[c] for r in rows}, key=str) for c in ("robot", "target", "F_max",
                                                                "stop_time")}
    fig.suptitle("Final relative error against initial base velocity ("
                 + "; ".join(f"{c} = {', '.join(v)}" for c, v in info.items()) + ")")
    nrow = -(-len(series_handles) // ncol)
    fig.tight_layout(rect=(0, 0.03 + 0.025 * nrow, 1, 1))
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return out_png
