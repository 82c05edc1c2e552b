"""Interface conformance: FMI cross-check files.

spacerobot.system.crosscheck writes, per FMU (plant, estimator, sensors), <Model>.fmu,
<Model>_ref.opt, <Model>_ref.csv and (estimator, sensors) <Model>_in.csv in the fmi-cross-check
layout. Here they are

- validated by the cross-check's own validator (fmpy.cross_check.validate_vendor_repo.
  validate_test_fmu, what the cross-check repository runs): no problem for any of the three,
  while a file with the comma-bearing input names is rejected (negative control);
- checked against the cross-check rules (opt entries via fmpy's reader, quoted header, time
  first and monotonic, names that exist in the FMU, every input whose name the validator can
  read in _in.csv, at most 10 reference variables, files under 1 MB, start and stop time
  present);
- checked for content: _in.csv equals the plant outputs from an independent fmpy simulate_fmu
  run of the plant FMU;
- re-simulated with fmpy.simulate_fmu (input from _in.csv, output interval = StepSize) and
  validated with fmpy's cross-check rule (fmpy.cross_check.validate_result: at most 10 % of the
  samples outside the band), with the strict form of it (fmpy.util.validate_result: no sample
  outside), and to RelTol pointwise;
- shown to be able to fail: a re-simulation with another target mass or another initial guess
  is rejected by the same validation.
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import pytest

from test_conformance_util import ROBOTS, fmus_for

from spacerobot.system import crosscheck as xc

STOP, STEP = 2.0, 0.1

# fmpy 0.3.32's cross_check module imports from the deprecated scipy.ndimage.filters
pytestmark = pytest.mark.filterwarnings("ignore:Please import:DeprecationWarning")


@pytest.fixture(scope="module", params=ROBOTS)
def artifacts(request, tmp_path_factory):
    robot = request.param
    fmus = fmus_for(request, robot)
    out = tmp_path_factory.mktemp(f"crosscheck_{robot}")
    folders = xc.write_crosscheck(robot, out, stop_time=STOP, step=STEP, fmus=fmus)
    return robot, fmus, folders


def _model(folder: Path) -> str:
    return folder.name


def test_layout_and_files(artifacts):
    from fmpy import platform

    robot, fmus, folders = artifacts
    for kind, folder in folders.items():
        model = xc.MODELS[kind]
        assert folder.parts[-7:] == ("fmus", "2.0", "cs", platform, "spacerobot", "0.1.0", model)
        expected = {f"{model}.fmu", f"{model}_ref.csv", f"{model}_ref.opt", "ReadMe.md"}
        if kind != "plant":
            expected.add(f"{model}_in.csv")
        assert {p.name for p in folder.iterdir()} == expected
        assert (folder / f"{model}.fmu").read_bytes() == Path(fmus[kind]).read_bytes()


def test_files_follow_the_cross_check_rules(artifacts):
    from fmpy import read_model_description

    robot, fmus, folders = artifacts
    for kind, folder in folders.items():
        model = _model(folder)
        md = read_model_description(str(folder / f"{model}.fmu"))
        causal = {c: [v.name for v in md.modelVariables if v.causality == c]
                  for c in ("input", "output")}
        opts = xc.read_ref_opt(folder / f"{model}_ref.opt")       # fmpy checks the required keys
        assert (opts["StartTime"], opts["StopTime"], opts["StepSize"]) == (0.0, STOP, STEP)
        assert 0 < opts["RelTol"] < 1e-3
        files = [("ref", causal["output"])] + ([("in", causal["input"])] if kind != "plant"
                                               else [])
        for suffix, allowed in files:
            path = folder / f"{model}_{suffix}.csv"
            assert path.stat().st_size < xc.MAX_CSV_BYTES
            lines = path.read_text().splitlines()
            header = next(csv.reader([lines[0]]))
            assert lines[0] == ",".join(f'"{h}"' for h in header)   # every name double-quoted
            assert header[0] == "time"
            assert set(header[1:]) <= set(allowed), set(header[1:]) - set(allowed)
            if suffix == "in":                               # every input the validator
                assert header[1:] == [n for n in allowed if "," not in n]   # reads, in order
                assert len(header) - 1 == len(allowed) - 9    # all but base.A's nine
            else:
                assert 1 <= len(header) - 1 <= 10            # "at most 10 important variables"
            for line in lines[1:]:
                assert '"' not in line and not line.endswith(",")
                assert len(line.split(",")) == len(header)
            data = xc.read_crosscheck_csv(path)
            t = data["time"]
            assert t[0] == 0.0 and abs(t[-1] - STOP) < 1e-12 and np.all(np.diff(t) > 0)
            assert np.all(np.isfinite(data.view((float, len(header)))))


@pytest.mark.parametrize("kind", ["estimator", "sensors"])
def test_inputs_are_the_plant_outputs(artifacts, kind):
    from fmpy import simulate_fmu

    robot, fmus, folders = artifacts
    folder = folders[kind]
    inputs = xc.read_crosscheck_csv(folder / f"{_model(folder)}_in.csv")
    names = list(inputs.dtype.names[1:])
    plant_names = [n.removeprefix("true.") if kind == "sensors" else n for n in names]
    plant = simulate_fmu(str(fmus["plant"]), stop_time=STOP, output_interval=STEP,
                         output=plant_names)
    assert np.allclose(plant["time"], inputs["time"], rtol=0, atol=1e-12)
    for n, pn in zip(names, plant_names):
        assert np.array_equal(plant[pn], inputs[n]), n


def test_the_cross_check_validator_passes_every_fmu(artifacts, tmp_path):
    """fmpy's validate_test_fmu, as the cross-check repository runs it, on each folder; and a
    negative control: the estimator's inputs with the nine base.A columns added (quoted, as the
    rules write them) are rejected, so the pass above means something."""
    import shutil

    from fmpy.cross_check.validate_vendor_repo import validate_test_fmu

    robot, fmus, folders = artifacts
    for kind, folder in folders.items():
        assert validate_test_fmu(str(folder)) == [], kind
    est = folders["estimator"]
    bad = tmp_path / Path(*est.parts[-7:])
    shutil.copytree(est, bad)
    model = _model(est)
    inputs = xc.read_crosscheck_csv(bad / f"{model}_in.csv")
    names = [*inputs.dtype.names[1:], *(f"base.A[{i},{j}]" for i in (1, 2, 3) for j in (1, 2, 3))]
    data = np.column_stack([*(inputs[n] for n in inputs.dtype.names[1:]),
                            *([np.zeros(len(inputs))] * 9)])
    xc.write_crosscheck_csv(bad / f"{model}_in.csv", inputs["time"], names, data)
    problems = validate_test_fmu(str(bad))
    assert problems and "columns instead of" in problems[0], problems


def _resimulate(kind, folder, start_values=None, input_scale=None):
    from fmpy import simulate_fmu

    model = _model(folder)
    opts = xc.read_ref_opt(folder / f"{model}_ref.opt")
    ref = xc.read_crosscheck_csv(folder / f"{model}_ref.csv")
    inputs = None
    if kind != "plant":
        inputs = xc.read_crosscheck_csv(folder / f"{model}_in.csv")
        if input_scale:
            name, factor = input_scale
            inputs[name] = inputs[name] * factor
    res = simulate_fmu(str(folder / f"{model}.fmu"), start_time=opts["StartTime"],
                       stop_time=opts["StopTime"], output_interval=opts["StepSize"],
                       input=inputs, output=list(ref.dtype.names[1:]),
                       start_values=start_values or {})
    return ref, res, opts


@pytest.mark.parametrize("kind", ["plant", "estimator", "sensors"])
def test_resimulation_passes_fmpy_cross_check_validation(artifacts, kind):
    from fmpy.cross_check import validate_result as cross_check_rule
    from fmpy.util import validate_result as outliers

    robot, fmus, folders = artifacts
    ref, res, opts = _resimulate(kind, folders[kind])
    assert cross_check_rule(res, ref, opts["StartTime"], opts["StopTime"]) is None
    assert outliers(result=res, reference=ref, stop_time=opts["StopTime"]) == 0
    assert np.allclose(res["time"], ref["time"], rtol=0, atol=1e-12)
    for n in ref.dtype.names[1:]:
        scale = max(np.max(np.abs(ref[n])), 1e-300)
        assert np.max(np.abs(res[n] - ref[n])) <= opts["RelTol"] * scale, n


@pytest.mark.parametrize("kind,change", [
    ("plant", {"start_values": {"target.m": 100.0}}),
    ("estimator", {"start_values": {"guess.target.m": 400.0, "guess.base.m": 300.0}}),
    ("estimator", {"input_scale": ("thrust.J[1]", 1.5)}),
    ("sensors", {"start_values": {"seed": 7}}),
    ("sensors", {"input_scale": ("true.thrust.J[1]", 1.5)}),
], ids=["plant-other-target", "estimator-other-guess", "estimator-other-input",
        "sensors-other-seed", "sensors-other-input"])
def test_validation_rejects_a_different_run(artifacts, kind, change):
    """Negative control: the validation is discriminating."""
    from fmpy.util import validate_result as outliers

    robot, fmus, folders = artifacts
    ref, res, opts = _resimulate(kind, folders[kind], **change)
    assert outliers(result=res, reference=ref, stop_time=opts["StopTime"]) > 0


def test_register_adds_the_crosscheck_subcommand(tmp_path, monkeypatch):
    parser = argparse.ArgumentParser(prog="spacerobot")
    sub = parser.add_subparsers(dest="command")
    xc.register(sub)
    out = tmp_path / "xc"
    args = parser.parse_args(["crosscheck", "--robot", "planar", "--out", str(out),
                              "--stop-time", "0.5"])
    assert args.func is xc.run_cli
    assert args.func(args) == 0
    folder = out / "fmus" / "2.0" / "cs"
    assert len(list(folder.rglob("*_ref.csv"))) == 3
    assert not (out / "_build").exists()


def test_spacerobot_cli_runs_crosscheck(tmp_path, capsys):
    cli = pytest.importorskip("spacerobot.system.cli")
    out = tmp_path / "cli"
    assert cli.main(["crosscheck", "--robot", "spatial", "--out", str(out),
                     "--stop-time", "0.3"]) == 0
    printed = capsys.readouterr().out.split()
    est = next(p for p in printed if p.endswith("SpaceRobotEstimator_in.csv"))
    data = xc.read_crosscheck_csv(Path(est))
    assert len(data) == 4 and "arm.q[6]" in data.dtype.names      # the spatial robot
