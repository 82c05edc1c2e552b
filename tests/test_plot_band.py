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


def _axes_of(monkeypatch):
    """{panel title's first word: axes} of the figure plot_run saves."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.figure
    panels = {}
    orig = matplotlib.figure.Figure.savefig

    def spy(fig, *a, **k):
        panels.update({ax.get_title().split()[0].rstrip(":"): ax for ax in fig.axes
                       if ax.get_visible()})
        return orig(fig, *a, **k)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    return panels


def _identify_like(t):
    """What spacerobot identify writes for a planar run: bare names, sd columns whose first
    value is the prior's (huge), truth.<name> copied from the telemetry."""
    m = 250.0 * (1 + 0.2 * np.exp(-t))
    sd_m = np.where(t == 0.0, 1e18, 0.5 * np.exp(-t) + 1e-3)
    izz = 10.41 * (1 - 0.1 * np.exp(-2 * t))
    sd_izz = np.where(t == 0.0, 3e17, 0.05 * np.exp(-t))
    bx = 0.001 * np.exp(-t)
    return {"time": t, "target.m": m, "sd.target.m": sd_m, "target.Izz": izz,
            "sd.target.Izz": sd_izz, "target.b[3]": bx, "sd.target.b[3]": sd_m * 1e-3,
            "truth.target.m": np.full_like(t, 250.0), "truth.target.Izz": np.full_like(t, 10.41),
            "truth.target.b[3]": np.zeros_like(t)}


def test_identify_output_is_plotted_against_its_truth_with_sensible_limits(tmp_path, monkeypatch):
    """docs/telemetry.md's round trip: spacerobot plot of identify's output compares with the
    truth columns it carries, and a band of 1e18 at t = 0 does not set the y-axis."""
    t = np.linspace(0.0, 10.0, 101)
    data = _identify_like(t)
    path = write_csv(tmp_path / "estimates.csv", data)
    panels = _axes_of(monkeypatch)
    plot.plot_run(path)
    assert set(panels) == {"target.m", "target.Izz", "target.b[3]"}
    assert panels["target.m"].get_title().startswith("target.m / truth (250)")
    assert "absolute error (truth = 0)" in panels["target.b[3]"].get_title()
    for name, ax in panels.items():
        lo, hi = ax.get_ylim()
        assert "no truth" not in ax.get_title(), name
        assert hi - lo < 1.0, (name, lo, hi)                   # not stretched by the band
    lo, hi = panels["target.m"].get_ylim()
    half = data["target.m"][50:] / 250.0                         # the settled half is shown
    assert lo <= half.min() and half.max() <= hi


def test_without_truth_the_axis_follows_the_estimate(tmp_path, monkeypatch):
    t = np.linspace(0.0, 10.0, 101)
    data = {k: v for k, v in _identify_like(t).items() if not k.startswith("truth.")}
    path = write_csv(tmp_path / "telemetry-identified.csv", data)
    panels = _axes_of(monkeypatch)
    plot.plot_run(path)
    lo, hi = panels["target.m"].get_ylim()
    assert "no truth in CSV" in panels["target.m"].get_title()
    settled = data["target.m"][50:]
    assert lo <= settled.min() and settled.max() <= hi
    assert hi - lo < 0.1 * 250.0                                # not 1e18


def test_an_estimate_a_projection_moved_for_a_while_is_not_plotted_as_identified():
    """A planar run's out-of-plane moment keeps its guess but for a while where the physical
    projection moved it (base.Ixx 100 -> 120 -> 100): it is no identified parameter; one that
    ends elsewhere than its guess is."""
    t = np.linspace(0.0, 10.0, 101)
    moved = np.where((t > 1.0) & (t < 3.0), 120.0, 100.0)
    data = {"estimator.base.Ixx": moved, "estimator.base.Izz": 100.0 - 16.4 * (1 - np.exp(-t))}
    assert plot.identified(data) == ["base.Izz"]
