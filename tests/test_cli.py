"""The ``spacerobot`` command line, run as a subprocess (build, run, plot) and in-process."""
from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import spacerobot
from spacerobot import ESTIMATE_NAMES, read_csv
from spacerobot.robots import PAPER_PLANAR_MEDIUM, TARGETS
from spacerobot.system import cli

CLI = [sys.executable, "-m", "spacerobot.system.cli"]


def _run(args, cwd, check=True):
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    p = subprocess.run(CLI + [str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                       env=env, timeout=300)
    if check:
        assert p.returncode == 0, f"spacerobot {' '.join(map(str, args))} failed:\n{p.stderr}"
    return p


def _table(stdout: str) -> dict:
    """``{parameter: (estimate, truth, paper or None)}`` parsed from the printed table."""
    rows = {}
    for line in stdout.splitlines():
        parts = line.split()
        if parts and parts[0] in ESTIMATE_NAMES:
            est, truth = float(parts[1]), float(parts[2])
            rest = parts[3:]
            err_len = 2      # "0.00012 %" or "abs 1.2e-05"
            paper = None
            if len(rest) > err_len:
                try:
                    paper = float(rest[err_len])
                except ValueError:
                    paper = None
            rows[parts[0]] = (est, truth, paper)
    return rows


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("cli")


@pytest.fixture(scope="module")
def built(workdir) -> dict:
    p = _run(["build", "--robot", "planar", "--out", "b"], cwd=workdir)
    paths = dict(line.split(None, 1) for line in p.stdout.splitlines() if line.strip())
    return {k: workdir / v.strip() for k, v in paths.items()}


def test_build_prints_existing_paths(built):
    assert {"plant", "estimator", "ssd", "ssp"} <= set(built)
    for key, path in built.items():
        assert path.is_file(), f"{key}: {path}"
    assert built["ssp"].name == "planar.ssp"
    assert {f"ssv:{n}" for n in TARGETS["planar"]} <= set(built)


@pytest.fixture(scope="module")
def planar_run(built, workdir):
    """``spacerobot run <planar.ssp> --stop-time 2``: (completed process, CSV path)."""
    out = workdir / "r" / "medium.csv"
    p = _run(["run", built["ssp"], "--stop-time", "2", "--out", out, "--no-progress"],
             cwd=workdir)
    return p, out


def test_run_prints_table_with_paper_values_and_writes_csv(planar_run):
    p, out = planar_run
    table = _table(p.stdout)
    assert set(table) == set(ESTIMATE_NAMES)
    data = read_csv(out)
    assert data["time"][-1] == pytest.approx(2.0)
    assert len(data["time"]) == 21
    paper = PAPER_PLANAR_MEDIUM["momentum"]
    target = TARGETS["planar"]["medium"]
    for name, (est, truth, pv) in table.items():
        assert est == pytest.approx(data["estimator." + name][-1], abs=1e-6)
        assert truth == pytest.approx(data["plant." + name][-1], rel=1e-5, abs=1e-9)
        assert (pv is not None) == (name in paper), name
        if pv is not None:
            assert pv == pytest.approx(paper[name], abs=0.006)
    assert table["target.m"][1] == target.mass
    assert "not identified" in p.stdout          # planar: Ixx etc. keep their guesses
    assert str(out) in p.stdout


@pytest.mark.slow
def test_run_robot_builds_if_needed_and_uses_default_csv_name(workdir):
    d = workdir / "auto"
    d.mkdir()
    p = _run(["run", "--robot", "planar", "--build-dir", "bd", "--target", "small",
              "--method", "force", "--accel", "differenced", "--stop-time", "1"], cwd=d)
    assert (d / "bd" / "planar.ssp").is_file()
    # the default name holds method, acceleration source, solver and the explicit stop time:
    # runs do not overwrite
    csv_path = d / "results" / "planar-small-force-differenced-paper-t1.csv"
    assert csv_path.is_file()
    table = _table(p.stdout)
    assert table["target.m"][1] == TARGETS["planar"]["small"].mass
    assert all(pv is None for _, _, pv in table.values())       # no paper values for small


@pytest.mark.slow
def test_run_fmi3_builds_and_runs_in_one_step(workdir):
    """``run --robot R --fmi-version 3``: the FMI 3.0 FMUs and their .ssp are built into
    build/<robot>-fmi3/ and run; the results equal the FMI 2.0 system's (the same core and
    layer); a second run finds the .ssp fresh (no build); an FMI 2.0 .ssp in that folder is
    rebuilt as FMI 3.0; --fmi-version with an SSP_FILE is refused."""
    from lxml import etree

    d = workdir / "fmi3"
    d.mkdir()
    args = ["run", "--robot", "planar", "--stop-time", "1", "--no-progress"]
    p3 = _run([*args, "--fmi-version", "3", "--out", "r3.csv"], cwd=d)
    assert "building the FMI 3.0 FMUs" in p3.stderr
    ssp = d / "build" / "planar-fmi3" / "planar.ssp"
    with zipfile.ZipFile(ssp) as zf:
        fmus = [n for n in zf.namelist() if n.endswith(".fmu")]
        for n in fmus:
            inner = zipfile.ZipFile(zf.open(n))
            assert etree.fromstring(inner.read("modelDescription.xml")).get("fmiVersion") == "3.0"
    assert len(fmus) == 2
    p2 = _run([*args, "--out", "r2.csv"], cwd=d)
    assert (d / "build" / "planar" / "planar.ssp").is_file()
    a, b = read_csv(d / "r3.csv"), read_csv(d / "r2.csv")
    assert list(a) == list(b) and len(a["time"]) == 11
    for name in a:
        assert np.array_equal(a[name], b[name]), name
    assert _table(p3.stdout) == _table(p2.stdout)
    again = _run([*args, "--fmi-version", "3", "--out", "r3.csv"], cwd=d)
    assert "building" not in again.stderr
    shutil.copy2(d / "build" / "planar" / "planar.ssp", ssp)          # an FMI 2.0 system there
    os.utime(ssp)
    again = _run([*args, "--fmi-version", "3", "--out", "r3.csv"], cwd=d)
    assert "building the FMI 3.0 FMUs" in again.stderr
    bad = _run(["run", str(ssp), "--fmi-version", "3"], cwd=d, check=False)
    assert bad.returncode != 0 and "--fmi-version goes with --robot" in bad.stderr


def test_run_reports_fmu_errors(built, workdir):
    p = _run(["run", built["ssp"], "--stop-time", "1", "--out", workdir / "bad.csv",
              "--set", "plant.base.m=-1"], cwd=workdir, check=False)
    assert p.returncode == 1
    first, *rest = p.stderr.strip().splitlines()
    assert first.startswith(f"spacerobot run: error: {built['ssp']}: component 'plant' returned "
                            "Error from fmi2ExitInitializationMode")
    assert any("base.m must be > 0 kg" in line for line in rest)   # the FMU's message
    assert "Traceback" not in p.stderr


# ---------------------------------------------------------------------------------------------
# bad input: one line naming the user's file or value, a non-zero exit, no traceback
# ---------------------------------------------------------------------------------------------

def _main(args, capsys) -> tuple:
    """``cli.main(args)`` in-process: (exit status, stderr lines)."""
    status = cli.main([str(a) for a in args])
    return status, capsys.readouterr().err.strip().splitlines()


def _repack(ssp: Path, out: Path, change) -> Path:
    """A copy of ``ssp`` with ``change(name, bytes) -> bytes or None (left out)`` applied."""
    with zipfile.ZipFile(ssp) as src, zipfile.ZipFile(out, "w") as dst:
        for name in src.namelist():
            data = change(name, src.read(name))
            if data is not None:
                dst.writestr(name, data)
    return out


def test_corrupt_fmu_inside_the_ssp(built, tmp_path):
    bad = _repack(built["ssp"], tmp_path / "corrupt.ssp", lambda n, b: (
        b[: len(b) // 2] if n.endswith("SpaceRobotPlant.fmu") else b))
    p = _run(["run", bad, "--stop-time", "0.2", "--out", tmp_path / "x.csv"], cwd=tmp_path,
             check=False)
    assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr
    assert p.stderr.strip().splitlines() == [
        f"spacerobot run: error: {bad}: component 'plant': resources/SpaceRobotPlant.fmu is "
        "not a valid FMU (BadZipFile: File is not a zip file)"]


def test_malformed_ssd_xml(built, tmp_path, capsys):
    bad = _repack(built["ssp"], tmp_path / "broken.ssp", lambda n, b: (
        b.replace(b"</ssd:System>", b"</ssd:Sys>") if n == "SystemStructure.ssd" else b))
    status, err = _main(["run", bad, "--out", tmp_path / "x.csv"], capsys)
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith(f"spacerobot run: error: {bad}: SystemStructure.ssd or a parameter "
                             "set in it is not well-formed XML")


def test_zip_without_ssd_names_the_users_file(built, tmp_path, capsys):
    bad = _repack(built["ssp"], tmp_path / "nossd.ssp",
                  lambda n, b: None if n == "SystemStructure.ssd" else b)
    status, err = _main(["run", bad, "--out", tmp_path / "x.csv"], capsys)
    assert (status, err) == (1, [f"spacerobot run: error: {bad} has no SystemStructure.ssd: "
                                 "not an SSP package"])
    plain = tmp_path / "notes.txt"
    plain.write_text("not a zip")
    status, err = _main(["run", plain, "--out", tmp_path / "x.csv"], capsys)
    assert (status, err) == (1, [f"spacerobot run: error: {plain} is neither a folder nor a "
                                 ".ssp (zip) archive"])


def test_missing_file_and_bad_values(tmp_path, capsys):
    missing = tmp_path / "nope.ssp"
    status, err = _main(["run", missing], capsys)
    assert (status, err) == (1, [f"spacerobot run: error: {missing} does not exist"])
    status, err = _main(["plot", missing], capsys)
    assert status == 1 and len(err) == 1 and str(missing) in err[0], err
    status, err = _main(["run", "--robot", "planar", "--set", "plant.F_max=ten",
                         "--out", tmp_path / "x.csv"], capsys)
    assert (status, err) == (1, ["spacerobot run: error: --set plant.F_max: 'ten' is not a "
                                 "number"])


def test_out_is_checked_before_the_run(built, tmp_path, capsys, monkeypatch):
    """A folder or an unwritable place as --out fails at once, before the .ssp is opened."""
    from spacerobot.system import runner
    monkeypatch.setattr(runner, "open_system", lambda *a: pytest.fail("the run started"))
    status, err = _main(["run", built["ssp"], "--out", tmp_path], capsys)
    assert (status, err) == (1, [f"spacerobot run: error: {tmp_path} is a directory; give a "
                                 "file name for the results"])
    blocker = tmp_path / "file"
    blocker.write_text("")
    status, err = _main(["run", built["ssp"], "--out", blocker / "r.csv"], capsys)
    assert status == 1 and len(err) == 1 and str(blocker / "r.csv") in err[0], err


def test_out_must_be_a_csv_file(built, tmp_path, capsys, monkeypatch):
    """A typo such as --out README.md is refused before the run; the file is untouched."""
    from spacerobot.system import runner
    monkeypatch.setattr(runner, "open_system", lambda *a: pytest.fail("the run started"))
    keep = tmp_path / "README.md"
    keep.write_text("keep me")
    status, err = _main(["run", built["ssp"], "--out", keep], capsys)
    assert (status, err) == (1, [f"spacerobot run: error: --out {keep}: the result file must "
                                 "end in .csv"])
    assert keep.read_text() == "keep me"


def test_paper_values_only_beside_the_papers_scenario(built, workdir):
    p = _run(["run", built["ssp"], "--stop-time", "0.5", "--set", "plant.target.m=300",
              "--out", workdir / "changed.csv"], cwd=workdir)
    table = _table(p.stdout)
    assert table["target.m"][1] == 300.0
    assert all(pv is None for _, _, pv in table.values())
    assert "identified (sd below ident.sd_rel): base " in p.stdout


def test_plot_of_a_file_that_is_not_a_result_csv(tmp_path, capsys):
    text = tmp_path / "notes.md"
    text.write_text("# title\n\nsome, words, here\nand more\n")
    status, err = _main(["plot", text], capsys)
    assert status == 1 and len(err) == 1 and str(text) in err[0], err
    assert "not a result CSV" in err[0], err


def test_ctrl_c_stops_cleanly(built, tmp_path, capsys, monkeypatch):
    """SIGINT during the stepping loop: the loop stops at the next communication point, every
    FMU instance is freed, exit status 130 with one line."""
    import signal

    from fmpy.fmi2 import FMU2Slave
    from spacerobot.system.master import Master

    freed, steps = [], []
    orig_free, orig_step = FMU2Slave.freeInstance, Master.do_step

    def free(slave):
        freed.append(slave.instanceName)
        return orig_free(slave)

    def do_step(self, t, dt):
        steps.append(t)
        if len(steps) == 3:
            signal.raise_signal(signal.SIGINT)          # what Ctrl-C in the terminal sends
        return orig_step(self, t, dt)
    monkeypatch.setattr(FMU2Slave, "freeInstance", free)
    monkeypatch.setattr(Master, "do_step", do_step)
    # Python's own Ctrl-C handler, as in a terminal (a process started in the background by a
    # non-interactive shell inherits SIGINT ignored, and Python then installs none)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        status, err = _main(["run", built["ssp"], "--stop-time", "5", "--out",
                             tmp_path / "x.csv"], capsys)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert (status, err) == (130, ["spacerobot run: interrupted"])
    assert len(steps) == 3                              # stopped before the fourth step
    assert sorted(freed) == ["estimator", "plant"]
    assert not (tmp_path / "x.csv").exists()


def test_version():
    p = subprocess.run([sys.executable, "-m", "spacerobot", "--version"], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0
    assert p.stdout.strip() == f"spacerobot {spacerobot.__version__}"


@pytest.mark.slow
def test_plot_writes_png(planar_run, workdir):
    csv_path = planar_run[1]
    png = workdir / "fig" / "run.png"
    p = _run(["plot", csv_path, "--out", png], cwd=workdir)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(png) in p.stdout
    p = _run(["plot", csv_path], cwd=workdir)                    # default: next to the CSV
    assert csv_path.with_suffix(".png").is_file()


def test_plot_titles_zero_truth_panels_as_absolute_error(tmp_path, monkeypatch):
    """In-process: a zero-truth parameter is plotted as absolute error, and the title says so."""
    import matplotlib.figure

    t = np.linspace(0, 2, 21)
    data = {"time": t,
            "plant.base.m": np.full_like(t, 500.0), "estimator.base.m": 500 + np.exp(-t),
            "plant.target.b[2]": np.zeros_like(t), "estimator.target.b[2]": 0.01 * np.exp(-t),
            "plant.base.Ixx": np.full_like(t, 83.0), "estimator.base.Ixx": np.full_like(t, 100.0)}
    from spacerobot.system.recorder import write_csv
    path = write_csv(tmp_path / "x.csv", data)
    titles = []
    orig = matplotlib.figure.Figure.savefig

    def spy(fig, *a, **k):
        titles.extend(ax.get_title() for ax in fig.axes if ax.get_visible())
        return orig(fig, *a, **k)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    assert cli.main(["plot", str(path), "--out", str(tmp_path / "x.png")]) == 0
    assert (tmp_path / "x.png").is_file()
    assert any("target.b[2]" in s and "absolute error" in s for s in titles)
    assert any(s.startswith("base.m / truth") for s in titles)
    assert not any("Ixx" in s for s in titles)                  # constant: not identified


def test_plot_dispatches_sweep_tables(tmp_path, monkeypatch):
    sweep = pytest.importorskip("spacerobot.system.sweep")
    calls = []
    monkeypatch.setattr(sweep, "plot_sweep", lambda c, o, **k: calls.append((c, o)) or o)
    path = tmp_path / "sweep.csv"
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows([["sweep_id", "status"], ["abc", "ok"]])
    assert cli.main(["plot", str(path), "--out", str(tmp_path / "s.png")]) == 0
    assert calls == [(str(path), str(tmp_path / "s.png"))]


@pytest.mark.slow
def test_help_lists_commands():
    p = subprocess.run(CLI + ["--help"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0
    for cmd in ("build", "run", "plot"):
        assert cmd in p.stdout
    exe = shutil.which("spacerobot")
    if exe:                                   # the installed console script is the same CLI
        q = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=120)
        assert q.returncode == 0 and q.stdout == p.stdout


@pytest.mark.parametrize("argv,expected", [
    (["--target", "depletion"], 300.0),                   # the set's own duration
    (["--target", "depletion", "--stop-time", "12"], 12.0),
    (["--target", "default"], None),                      # the SSD's default experiment
    ([], None)])
def test_run_uses_the_parameter_sets_duration(monkeypatch, capsys, tmp_path, argv, expected):
    """`run --target depletion` runs the 300 s the set is made for (robots.PARAMETER_SETS), an
    explicit --stop-time wins, other sets keep the SSD's default experiment."""
    from spacerobot.robots import PARAMETER_SETS
    from spacerobot.system import runner, ssd
    assert PARAMETER_SETS["spatial"]["depletion"].stop_time == 300.0
    seen = {}

    def fake_run(ssp, **kw):
        seen.update(kw)
        raise RuntimeError("stop here")

    monkeypatch.setattr(ssd, "ensure_ssp", lambda *a, **k: tmp_path / "spatial.ssp")
    monkeypatch.setattr(runner, "run_ssp", fake_run)
    with pytest.raises(RuntimeError, match="stop here"):
        cli.main(["run", "--robot", "spatial", "--out", str(tmp_path / "r.csv"), *argv])
    assert seen["stop_time"] == expected


# ---------------------------------------------------------------------------------------------
# issue #28: results named by their settings, replacements announced, slow steps announced,
# a closed pipe ends quietly
# ---------------------------------------------------------------------------------------------

def _fake_run(monkeypatch, tmp_path, built_calls=None):
    """``cli.main(['run', ...])`` without FMUs: ensure_ssp and run_ssp record their arguments
    and run_ssp returns a tiny result (the CSV path it was given is recorded, not written)."""
    from spacerobot.system import runner, ssd
    seen = {}

    def ensure(robot, out_dir=None, sensors=False, on_build=None, **kw):
        out = Path(out_dir) if out_dir else Path("build") / robot
        if on_build is not None and built_calls is not None:
            on_build(out)
            built_calls.append(out)
        return tmp_path / "fake.ssp"

    def run(ssp, **kw):
        seen.update(kw)
        t = np.array([0.0, 0.1])
        return runner.RunResult(time=t, data={"time": t}, truth={"target.m": 250.0},
                                final={"target.m": 250.0}, csv_path=kw["csv_path"])
    monkeypatch.setattr(ssd, "ensure_ssp", ensure)
    monkeypatch.setattr(runner, "run_ssp", run)
    return seen


def test_default_name_holds_the_set_overrides_and_the_stop_time(monkeypatch, tmp_path, capsys):
    """Runs that differ only in --set (or --stop-time) get their own default CSV; the same
    settings in another order the same one; a long list a stable 10-digit hash."""
    seen = _fake_run(monkeypatch, tmp_path)
    monkeypatch.chdir(tmp_path)

    def name(*extra):
        assert cli.main(["run", "--robot", "planar", "--no-progress", *extra]) == 0
        capsys.readouterr()
        return Path(seen["csv_path"]).name

    base = "planar-medium-momentum-measured-paper"
    assert name() == f"{base}.csv"
    assert name("--set", "plant.base.v0[1]=5") == f"{base}-plant.base.v0_1=5.csv"
    assert name("--set", "plant.base.v0[1]=6") == f"{base}-plant.base.v0_1=6.csv"
    two = name("--set", "plant.base.v0[1]=5", "--set", "estimator.lambda=0.98")
    assert two == f"{base}-estimator.lambda=0.98_plant.base.v0_1=5.csv"
    assert name("--set", "estimator.lambda=0.98", "--set", "plant.base.v0[1]=5.0") == two
    assert name("--stop-time", "30") == f"{base}-t30.csv"
    many = [a for i in range(8) for a in ("--set", f"plant.base.v0[{i % 3 + 1}]={i}.5")]
    long_name = name(*many, "--set", "estimator.P0_mu=12345.678")
    assert long_name.startswith(f"{base}-set-") and len(long_name) == len(base) + 19
    assert name("--set", "estimator.P0_mu=12345.678", *many) == long_name   # stable
    assert name("--set", "estimator.P0_mu=1", *many) != long_name


def test_replacing_a_result_is_announced(monkeypatch, tmp_path, capsys):
    """An existing result file is never replaced silently: one line on stderr before the run."""
    _fake_run(monkeypatch, tmp_path)
    out = tmp_path / "r.csv"
    assert cli.main(["run", "--robot", "planar", "--out", str(out)]) == 0
    assert capsys.readouterr().err == ""                     # a new file: nothing to say
    out.write_text("earlier result")
    assert cli.main(["run", "--robot", "planar", "--out", str(out)]) == 0
    assert capsys.readouterr().err.splitlines() == [
        f"spacerobot run: {out} exists: this run replaces it"]


def test_slow_steps_say_what_they_do_on_stderr(monkeypatch, tmp_path, capsys):
    """Building the FMUs (build, and run when the SSP is missing) says so in one line on
    stderr before it starts; a run of built FMUs says nothing (nothing compiles at run time)."""
    from spacerobot.system import ssd
    built_calls = []
    _fake_run(monkeypatch, tmp_path, built_calls)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "--robot", "planar", "--build-dir", "bd"]) == 0
    assert capsys.readouterr().err.splitlines() == [
        "spacerobot run: building the FMUs and the SSP for planar into bd/ ..."]
    monkeypatch.undo()
    monkeypatch.setattr(ssd, "build_system", lambda robot, out, sensors=False, **kw: {"ssp": out})
    assert cli.main(["build", "--robot", "planar", "--out", str(tmp_path / "b")]) == 0
    cap = capsys.readouterr()
    assert cap.err.splitlines() == [
        f"spacerobot build: building the FMUs and the SSP for planar into {tmp_path / 'b'}/ ..."]
    assert cap.out.split() == ["ssp", str(tmp_path / "b")]   # stdout: the result only


def test_montecarlo_says_what_it_starts(monkeypatch, tmp_path, capsys):
    mc = pytest.importorskip("spacerobot.system.montecarlo")

    def stop(*a, **k):
        raise ValueError("stopped before the study")
    monkeypatch.setattr(mc, "run_montecarlo", stop)
    out = tmp_path / "mc.csv"
    assert cli.main(["montecarlo", "--cases", "3", "--stop-time", "20", "--out", str(out)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[0] == (f"spacerobot montecarlo: 6 runs of 20 s (3 random cases x 2 methods x 1 "
                      f"excitation modes) on 2 local Dask workers, building the SSP first; results "
                      f"-> {out} ...")


def test_error_column_is_the_body_scaled_relative_error():
    """One metric in every row, named in the header: |est - truth| / error_scale(truth), here
    computed by hand (a product of inertia relative to the body's largest moment, a zero CoM
    component relative to 5 cm), not relative to its own (tiny) truth."""
    from spacerobot.system.runner import RunResult, format_results
    truth = {"base.m": 500.0, "base.b[1]": 0.0, "base.Ixx": 80.0, "base.Iyy": 90.0,
             "base.Izz": 100.0, "base.Ixy": 0.02}
    final = {"base.m": 501.0, "base.b[1]": 0.001, "base.Ixx": 80.0, "base.Iyy": 90.0,
             "base.Izz": 100.0, "base.Ixy": 0.0202}
    t = np.zeros(1)
    text = format_results(RunResult(time=t, data={}, truth=truth, final=final))
    head = text.splitlines()[0].split()
    assert head[:4] == ["parameter", "estimate", "truth", "error/scale"]
    rows = {line.split()[0]: line.split() for line in text.splitlines()[2:]
            if line.split() and line.split()[0] in truth}
    expected = {"base.m": 1.0 / 500.0, "base.b[1]": 0.001 / 0.05, "base.Ixx": 0.0,
                "base.Ixy": 0.0002 / 100.0}
    for n, rel in expected.items():
        assert float(rows[n][3]) == pytest.approx(100 * rel, abs=1e-5), n
        assert rows[n][4] == "%"
    assert "error/scale = |estimate - truth| / error_scale(truth)" in text


def _pipe_run(built, tmp_path, name):
    return [str(a) for a in CLI + ["run", built["ssp"], "--stop-time", "0.3", "--no-progress",
                                   "--out", tmp_path / name]]


@pytest.mark.slow
def test_closed_pipe_ends_quietly(built, tmp_path):
    """stdout closed by its reader before the table is printed: exit status 141 (128 +
    SIGPIPE, as Unix tools), no traceback, no error line; the CSV was written."""
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    p = subprocess.Popen(_pipe_run(built, tmp_path, "closed.csv"), cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()                                        # the reader is gone
    err = p.stderr.read().decode()
    assert p.wait(timeout=300) == 141, err
    assert err == "", err
    assert read_csv(tmp_path / "closed.csv")["time"][-1] == pytest.approx(0.3)


def test_head_one_ends_quietly(built, tmp_path):
    """`spacerobot run ... | head -1`, as a user types it: the first line, then a quiet end
    (0 if the table fitted in the pipe before head exited, else 141)."""
    cmd = " ".join(f"'{a}'" for a in _pipe_run(built, tmp_path, "head.csv"))
    p = subprocess.run(["bash", "-c", f"set -o pipefail; {cmd} | head -1"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300,
                       env=dict(os.environ, PYTHONWARNINGS="ignore"))
    assert p.returncode in (0, 141), p.stderr
    assert "Traceback" not in p.stderr and "Broken pipe" not in p.stderr, p.stderr
    assert p.stdout.startswith(str(built["ssp"]))
