"""Sweeps on a local Dask cluster: table columns, failure isolation, resume, CLI, plot.

Every sweep here uses short stop times (1-1.5 s) so that the whole module runs in well under
a minute and a half on two cores; one .ssp is built for the module and shared by the tests.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil

import pytest

from spacerobot import build_system
from spacerobot.system import sweep as sw
from spacerobot.system.sweep import (COLUMNS, PARAMS, Point, make_points, point_id, read_table,
                                     run_sweep)

RUNNER = sw.DEFAULT_RUNNER
STOP = 1.5


@pytest.fixture(scope="module")
def ssp(tmp_path_factory):
    """``{'planar': path}``: the system built once for this module."""
    built = build_system("planar", tmp_path_factory.mktemp("sweep_ssp") / "planar")
    return {"planar": str(built["ssp"])}


def _grid():
    # 2 methods x 2 velocities
    return make_points("planar", "medium", ["momentum", "force"], ["measured"],
                       [(0.0, 10.0), (50.0, 50.0)], 0.1, STOP)


@pytest.fixture(scope="module")
def sweep_2x2(ssp, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "sweep.csv"
    points = _grid()
    summary = run_sweep(points, out, workers=2, ssp=ssp, progress=False, runner=RUNNER)
    return out, points, summary


def _by_id(csv_path):
    return {r["sweep_id"]: r for r in read_table(csv_path)}


# ---------------------------------------------------------------------------------------------
def test_point_id_is_stable_and_parameter_sensitive():
    p = Point("planar", "medium", "momentum", "measured", (0, 10), 0.1, 60)
    # a literal: the id must not change between processes, runs or versions of the code
    assert p.id == point_id(Point("planar", "medium", "momentum", "measured", (0.0, 10.0, 0.0),
                                  0.1, 60.0))
    assert p.id == "718819a03716c7c7", p.id
    others = [Point("planar", "medium", "force", "measured", (0, 10), 0.1, 60),
              Point("planar", "small", "momentum", "measured", (0, 10), 0.1, 60),
              Point("planar", "medium", "momentum", "measured", (0, 10.5), 0.1, 60),
              Point("planar", "medium", "momentum", "measured", (0, 10), 0.2, 60),
              Point("planar", "medium", "momentum", "measured", (0, 10), 0.1, 30),
              Point("planar", "medium", "momentum", "differenced", (0, 10), 0.1, 60),
              Point("planar", "medium", "momentum", "measured", (0, 10), 0.1, 60,
                    {"plant.target.m": 200.0})]
    assert len({p.id, *[o.id for o in others]}) == 1 + len(others)
    # overrides: order does not matter
    a = Point(overrides={"plant.K_F": -2.0, "plant.target.m": 200.0})
    b = Point(overrides=(("plant.target.m", 200.0), ("plant.K_F", -2.0)))
    assert a.id == b.id


def test_grid_expansion_and_overrides():
    pts = make_points("planar", "medium", ["momentum", "force"], ["measured", "differenced"],
                      [(0, 10), (200, 200)], [0.1], [60])
    # momentum ignores the acceleration source: run once per velocity
    assert len(pts) == 2 + 4
    assert {(p.method, p.accel_source) for p in pts} == {
        ("momentum", "measured"), ("force", "measured"), ("force", "differenced")}
    ov = [p for p in pts if p.method == "force" and p.accel_source == "differenced"][0] \
        .fmi_overrides()
    assert ov["estimator.method"] == 2 and ov["estimator.accel_source"] == 2
    assert ov["plant.F_max"] == 0.1 and ov["plant.target.m"] == 250.0
    assert [ov[f"plant.base.v0[{i}]"] for i in (1, 2, 3)] in ([0, 10, 0], [200, 200, 0])
    with pytest.raises(ValueError, match="method"):
        Point(method="energy")
    # unspecified values are the robot's paper scenario
    sp = make_points("spatial", method="force")
    assert len(sp) == 1 and sp[0].target == "default" and sp[0].v0 == (10.0, 20.0, 30.0)
    assert (sp[0].F_max, sp[0].stop_time) == (10.0, 60.0)
    assert Point(robot="spatial").target == "default"
    assert sw.parse_v0("0,10;50,50;1,2,3") == [(0, 10), (50, 50), (1, 2, 3)]
    with pytest.raises(argparse.ArgumentTypeError):
        sw.parse_v0("0,10;5")


@pytest.mark.slow
def test_2x2_sweep_rows_and_columns(sweep_2x2):
    out, points, summary = sweep_2x2
    assert (summary.total, summary.submitted, summary.ok, summary.failed) == (4, 4, 4, 0), summary
    with open(out) as f:
        assert f.readline().rstrip("\r\n").split(",") == list(COLUMNS)
    rows = read_table(out)
    assert len(rows) == 4
    assert {r["sweep_id"] for r in rows} == {p.id for p in points}
    assert {(r["method"], float(r["v0_y"])) for r in rows} == {
        ("momentum", 10.0), ("momentum", 50.0), ("force", 10.0), ("force", 50.0)}
    for r in rows:
        assert r["status"] == "ok" and r["error"] == ""
        assert float(r["t_end"]) == pytest.approx(STOP)
        assert float(r["wall_time"]) > 0
        assert int(r["diag.samples"]) > 0
        # ran in a worker process, not here
        assert int(r["worker"].rsplit(":", 1)[1]) != os.getpid()
        assert float(r["true.target.m"]) == 250.0 and float(r["true.base.Izz"]) == 83.61
        for p in PARAMS:
            est, true, rel = (float(r[f"{k}.{p}"]) for k in ("est", "true", "relerr"))
            assert math.isfinite(est) and math.isfinite(rel)
            scale = abs(true) if true != 0 else (1.0 if ".b[" in p else
                                                 float(r[f"true.{p.split('.')[0]}.Ixx"]))
            assert rel == pytest.approx(abs(est - true) / scale, rel=1e-9, abs=1e-15)
        # the estimator really ran: the masses moved from the guesses (600 kg and 100 kg, i.e.
        # 20 % and 60 % off) towards the truth within 1.5 s (F_max = 0.1 N: weak excitation)
        assert float(r["relerr.base.m"]) < 0.15 and float(r["relerr.target.m"]) < 0.45
    # both worker processes of the 2-worker cluster took points
    assert len({r["worker"] for r in rows}) == 2


@pytest.mark.slow
def test_failed_point_is_reported_alone(ssp, tmp_path):
    out = tmp_path / "fail.csv"
    good = make_points("planar", "medium", "momentum", "measured", [(0, 10), (10, 0)], 0.1, 1.0)
    bad_mass = Point("planar", "medium", "momentum", "measured", (0, 10), 0.1, 1.0,
                     {"plant.target.m": -5.0})
    bad_fmax = Point("planar", "medium", "force", "measured", (0, 10), float("nan"), 1.0)
    summary = run_sweep(good + [bad_mass, bad_fmax], out, workers=2, ssp=ssp, progress=False,
                        runner=RUNNER)
    assert (summary.ok, summary.failed) == (2, 2), summary
    rows = _by_id(out)
    assert len(rows) == 4
    for p in good:
        assert rows[p.id]["status"] == "ok"
        assert math.isfinite(float(rows[p.id]["est.target.m"]))
    for p in (bad_mass, bad_fmax):
        r = rows[p.id]
        assert r["status"] == "failed"
        assert r["error"].strip(), "a failed point must carry its error message"
        assert r["est.target.m"] == "" and r["relerr.target.m"] == ""
    assert "plant.target.m" in rows[bad_mass.id]["overrides"]
    # the FMU's own reason reaches the table
    assert "target.m" in rows[bad_mass.id]["error"], rows[bad_mass.id]["error"]
    assert "F_max" in rows[bad_fmax.id]["error"], rows[bad_fmax.id]["error"]
    assert {pid for pid, _ in summary.failures} == {bad_mass.id, bad_fmax.id}
    # a re-run retries only the failed points, and keeps one row per point
    again = run_sweep(good + [bad_mass, bad_fmax], out, workers=2, ssp=ssp, progress=False,
                      runner=RUNNER)
    assert (again.skipped, again.submitted, again.failed) == (2, 2, 2), again
    rows2 = read_table(out)
    assert sorted(r["sweep_id"] for r in rows2) == sorted(rows)
    for p in good:   # untouched
        assert _by_id(out)[p.id] == rows[p.id]


@pytest.mark.slow
def test_rerun_skips_finished_points(sweep_2x2, ssp, tmp_path):
    src, points, _ = sweep_2x2
    out = tmp_path / "resume.csv"
    shutil.copy(src, out)
    before = out.read_bytes()
    summary = run_sweep(points, out, workers=2, ssp=ssp, progress=False, runner=RUNNER)
    assert (summary.skipped, summary.submitted) == (4, 0), summary
    assert out.read_bytes() == before
    # a second sweep cannot write to a table that one is writing to
    with sw._exclusive(out):
        with pytest.raises(sw.SweepLocked, match="another sweep"):
            run_sweep(points, out, workers=2, ssp=ssp, progress=False, runner=RUNNER)

    # an interrupted sweep: the last point's row never made it, and a partial line was left
    lines = before.decode().splitlines(keepends=True)
    lost = lines[-1].split(",", 1)[0]
    out.write_text("".join(lines[:-1]) + lines[-1][:25])
    kept = {k: v for k, v in _by_id(src).items() if k != lost}
    # this time on an existing cluster, given by its scheduler address (--scheduler)
    from distributed import LocalCluster
    with LocalCluster(n_workers=1, processes=True, threads_per_worker=1,
                      dashboard_address=":0") as cluster:
        summary = run_sweep(points, out, scheduler=cluster.scheduler_address, ssp=ssp,
                            progress=False, runner=RUNNER)
        assert len(cluster.scheduler.workers) == 1      # left running for its owner
    assert (summary.skipped, summary.submitted, summary.ok) == (3, 1, 1), summary
    rows = _by_id(out)
    assert set(rows) == {p.id for p in points} and len(read_table(out)) == 4
    for pid, r in kept.items():            # finished points were not re-run
        assert rows[pid]["wall_time"] == r["wall_time"] and rows[pid]["worker"] == r["worker"]


@pytest.mark.slow
def test_cli_config_and_plot(ssp, tmp_path, sweep_2x2):
    out = tmp_path / "cli.csv"
    cfg = tmp_path / "study.toml"
    cfg.write_text(f'robot = "planar"\ntarget = "medium"\nmethod = ["momentum"]\n'
                   f'F_max = 0.1\nstop_time = 1.0\nv0 = [[0, 10], [10, 0, 0]]\nworkers = 2\n'
                   f'out = "{out}"\n')
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="cmd")
    sw.register(sub)
    args = parser.parse_args(["sweep", "--config", str(cfg), "--dry-run"])
    assert args.func(args) == 0
    assert not out.exists()
    # command-line options take precedence over the file
    args = parser.parse_args(["sweep", "--config", str(cfg), "--method", "force",
                              "--build-dir", str(tmp_path / "b"), "--no-progress"])
    cfg_used = sw._settings(args)
    assert cfg_used["method"] == ["force"] and cfg_used["F_max"] == 0.1
    assert cfg_used["v0"] == [[0, 10], [10, 0, 0]]
    assert args.func(args) == 0
    rows = read_table(out)
    assert len(rows) == 2 and {r["method"] for r in rows} == {"force"}
    assert {r["status"] for r in rows} == {"ok"}

    png = sw.plot_sweep(sweep_2x2[0], tmp_path / "sweep.png")
    assert png.exists() and png.stat().st_size > 10_000
    with pytest.raises(ValueError, match="no successful"):
        bad = tmp_path / "empty.csv"
        bad.write_text(",".join(COLUMNS) + "\n")
        sw.plot_sweep(bad, tmp_path / "x.png")


def test_summary_lists_failures_in_id_order_not_completion_order():
    from spacerobot.system.sweep.execute import SweepSummary
    fails = [("b2", "FileNotFoundError: x"), ("a1", "ValueError: y"), ("c3", "KeyError: z")]
    texts = {str(SweepSummary(total=3, submitted=3, failed=3, failures=list(order)))
             for order in (fails, fails[::-1], fails[1:] + fails[:1])}
    assert len(texts) == 1
    text = texts.pop()
    assert text.index("a1") < text.index("b2") < text.index("c3")
