"""spacerobot plot draws the +-2 sd band the estimator reports around each estimate, in each
panel's units, for a run CSV and for the output of spacerobot identify."""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot.system import plot
from spacerobot.system.recorder import write_csv


def _record_fill_between(monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.axes import Axes

    calls = []
    original = Axes.fill_between

    def spy(self, x, y1, y2=0, **kw):
        calls.append((self, np.asarray(x), np.asarray(y1), np.asarray(y2)))
        return original(self, x, y1, y2, **kw)
    monkeypatch.setattr(Axes, "fill_between", spy)
    return calls


@pytest.mark.parametrize("prefix,truth_cols", [("estimator.", True), ("", False)])
def test_band_is_two_sd_around_the_estimate(tmp_path, monkeypatch, prefix, truth_cols):
    t = np.linspace(0.0, 10.0, 101)
    m = 250.0 * (1 + 0.1 * np.exp(-t))
    sd_m = 5.0 * np.exp(-t) + 0.01
    bx = 0.02 * np.exp(-t)                       # a CoM component whose truth is 0
    sd_bx = 0.01 * np.exp(-t / 2)
    data = {"time": t, prefix + "target.m": m, prefix + "sd.target.m": sd_m,
            prefix + "target.b[1]": bx, prefix + "sd.target.b[1]": sd_bx}
    if truth_cols:
        data.update({"plant.target.m": np.full_like(t, 250.0),
                     "plant.target.b[1]": np.zeros_like(t)})
    path = write_csv(tmp_path / "run.csv", data)
    calls = _record_fill_between(monkeypatch)
    png = plot.plot_run(path)
    assert png.exists() and png.stat().st_size > 0
    bands = {ax.get_title().split()[0].rstrip(":"): (y1, y2) for ax, _, y1, y2 in calls}
    lo, hi = bands["target.m"]
    div = 250.0 if truth_cols else 1.0
    assert np.allclose(lo, (m - 2 * sd_m) / div, rtol=1e-12)
    assert np.allclose(hi, (m + 2 * sd_m) / div, rtol=1e-12)
    lo, hi = bands["target.b[1]"]                # error (truth 0) or estimate: the same numbers
    assert np.allclose(lo, bx - 2 * sd_bx, rtol=1e-12, atol=1e-15)
    assert np.allclose(hi, bx + 2 * sd_bx, rtol=1e-12, atol=1e-15)


def test_no_sd_columns_no_band(tmp_path, monkeypatch):
    t = np.linspace(0.0, 1.0, 11)
    path = write_csv(tmp_path / "old.csv", {"time": t, "estimator.target.m": 1 + t,
                                            "plant.target.m": np.ones_like(t)})
    calls = _record_fill_between(monkeypatch)
    plot.plot_run(path)
    assert calls == []
    assert plot.sd_band({"estimator.target.m": t}, "target.m") is None
