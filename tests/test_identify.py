"""Recorded telemetry (spacerobot identify): a recorded co-simulation replayed through the
estimator core gives the live estimates (to 1e-12; the CSV keeps every digit, so in fact bit
for bit), with and without the sensors FMU, for both methods; the documented telemetry format
(bare interface names, accelerations optional); clear errors for bad files."""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot.interface import ESTIMATE_NAMES, measurement_vars
from spacerobot.robots import ROBOTS
from spacerobot.system import ssd
from spacerobot.system.cli import main
from spacerobot.system.identify import identify_csv
from spacerobot.system.recorder import read_csv, write_csv
from spacerobot.system.runner import run_ssp


@pytest.fixture(scope="module")
def planar_systems(tmp_path_factory, planar_fmus):
    root = tmp_path_factory.mktemp("identify")
    return {"two": ssd.build_system("planar", root / "two", fmus=planar_fmus),
            "sensors": ssd.build_system("planar", root / "sens", fmus=planar_fmus, sensors=True)}


def _assert_replay_equals_live(live, replay):
    """Live row k+1 (the FMU's outputs after consuming the sample of row k) = replay row k."""
    outs = [c[len("estimator."):] for c in live if c.startswith("estimator.")
            and c[len("estimator."):] in replay]
    assert set(ESTIMATE_NAMES) <= set(outs) and "sd.target.m" in outs and "diag.samples" in outs
    for n in outs:
        a, b = live["estimator." + n][1:], replay[n][:-1]
        assert np.all(np.abs(a - b) <= 1e-12 * np.maximum(1.0, np.abs(a))), n


#: the estimator's noise model (docs/identification.md, section 6), not its defaults
NOISE_MODEL = {"ident.sd_row.force_lin": 5.0, "ident.sd_row.force_ang": 3.0,
               "ident.diff_half_window": 2, "ident.corr_lags": 20}


@pytest.mark.parametrize("system,pset,method,accel,model", [
    ("two", "excited", "momentum", "measured", {}),
    ("two", "excited", "force", "differenced", {}),
    ("sensors", "realistic", "force", "measured", {}),
    ("sensors", "realistic", "momentum", "measured", {}),
    ("sensors", "realistic", "force", "differenced", NOISE_MODEL),
])
def test_recorded_run_replayed_gives_the_live_estimates(planar_systems, tmp_path, system, pset,
                                                        method, accel, model, capsys):
    csv = tmp_path / "run.csv"
    codes = {"momentum": 1, "force": 2, "measured": 1, "differenced": 2}
    overrides = {"estimator.method": codes[method], "estimator.accel_source": codes[accel]}
    overrides.update({f"estimator.{k}": v for k, v in model.items()})
    run_ssp(planar_systems[system]["ssp"], parameter_set=pset, stop_time=3.0, csv_path=csv,
            overrides=overrides, progress=False)
    out = tmp_path / "est.csv"
    sets = [a for k, v in model.items() for a in ("--set", f"{k}={v}")]
    assert main(["identify", str(csv), "--robot", "planar", "--method", method, "--accel",
                 accel, "--out", str(out)] + sets) == 0
    printed = capsys.readouterr().out
    assert "target.m" in printed and "CSV: " in printed
    live, replay = read_csv(csv), read_csv(out)
    _assert_replay_equals_live(live, replay)
    lag = 2 * model.get("ident.diff_half_window", 1)     # reference / differencing window
    assert replay["diag.samples"][-1] >= len(replay["time"]) - lag    # every sample used
    # the truth columns of the recorded run make the table's truth
    assert f"{live['plant.target.m'][0]:.6g}" in printed


def test_documented_format_bare_names_and_no_accelerations(planar_systems, tmp_path):
    csv = tmp_path / "run.csv"
    run_ssp(planar_systems["two"]["ssp"], parameter_set="excited", stop_time=3.0, csv_path=csv,
            progress=False)
    live = read_csv(csv)
    n = ROBOTS["planar"].n_joints
    names = [v.name for v in measurement_vars(n, "input")
             if v.key[0] not in ("a_S", "alpha_B", "qdd")]
    telemetry = {"time": live["time"], **{nm: live["plant." + nm] for nm in names}}
    path = write_csv(tmp_path / "telemetry.csv", telemetry)
    res = identify_csv(path, "planar")
    assert res.csv_path == tmp_path / "telemetry-identified.csv"
    assert res.truth == {}                                 # no truth columns: none claimed
    _assert_replay_equals_live(live, read_csv(res.csv_path))   # momentum: no accelerations used


def test_bad_telemetry_is_refused_with_a_clear_message(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,base.r[1]\n0,1\n")
    with pytest.raises(ValueError, match="no 'time' column"):
        identify_csv(bad, "planar")
    bad.write_text("time,base.r[1]\n0,1\n0,2\n")
    with pytest.raises(ValueError, match="strictly increasing"):
        identify_csv(bad, "planar")
    bad.write_text("time,base.r[1]\n0,1\n0.1,2\n")
    with pytest.raises(ValueError, match=r"no column for base\.r\[2\]"):
        identify_csv(bad, "planar")
    assert main(["identify", str(bad), "--robot", "planar"]) == 1
    assert "spacerobot identify: error:" in capsys.readouterr().err
    with pytest.raises(KeyError, match="not an estimator parameter"):
        identify_csv(bad, "planar", overrides={"guess.target.mass": 1.0})


def test_truth_is_the_current_one_at_the_end():
    """A run of a base that uses propellant records the dry-base parameter (plant.base.m) and
    the current base (plant.truth.base.m): the truth compared is the current one at the end,
    as the runner compares."""
    from spacerobot.system.identify import read_truth
    data = {"time": np.array([0.0, 0.1]), "plant.base.m": np.array([500.0, 500.0]),
            "plant.truth.base.m": np.array([510.0, 505.0]),
            "plant.target.m": np.array([250.0, 250.0])}
    assert read_truth(data, ["base.m", "target.m"]) == {"base.m": 505.0, "target.m": 250.0}
