"""The estimator's noise profile (``ident.noise_profile``, native/src/noise_profile.c;
docs/identification.md "One switch"): the options it sets from the sensors' parameters,
checked against the rules written out here from docs/sensors.md and the noise benchmark's
settings (not the code's own output); that it leaves a user's setting and, with profile 0,
everything alone; clear errors for bad values (library and FMU); the ``realistic`` parameter
set binds it; and that it turns the estimator's defaults' unusable answers under realistic
sensors into usable ones (closed loop through the SSP with the sensors FMU, truth known).
"""
from __future__ import annotations

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from spacerobot import interface
from spacerobot.core.estimator import default_options, profile_options
from spacerobot.interface import NOISE_PARAMETERS, SENSOR_MAGNITUDES
from spacerobot.sensors import default_parameters, estimator_noise_settings

ROOT = Path(__file__).resolve().parents[1]
DT = 0.1


def sensors(scale: float = 1.0, **changed) -> dict:
    """Profile options for the sensors' realistic defaults (docs/sensors.md) with ``changed``
    magnitudes (names without ``noise.``)."""
    p = default_parameters()
    p.update(changed)
    return {"noise_profile": 1, "noise_scale": scale, "noise_dt": DT,
            "noise": [p[n[len("noise."):]] for n in SENSOR_MAGNITUDES]}


def expected(method: int, accel: int, scale: float = 1.0, dt: float = DT) -> dict:
    """The options the profile should set, from the documented rules: densities over 1 s
    become d / sqrt(dt) per sample, every magnitude times noise.scale; the method's
    equation settings of the noise benchmark (benchmarks/noise.py SETTINGS)."""
    d = {k: scale * v for k, v in default_parameters().items()}
    out = {"sd_thrust_scale": d["thrust.scale"], "sd_thrust_misalign": d["thrust.misalign"],
           "signal_sd": [d["accel.vrw"] / math.sqrt(dt), d["alpha"], d["enc.qdd"], d["nav.v"],
                         d["gyro.arw"] / math.sqrt(dt), d["enc.qd"]]}
    # the sensors have white noise: the information filter reports (information.h)
    out["information"] = 1
    if method == 1:
        out.update(momentum_window=5.0, momentum_point=1, corr_lags=round(5.0 / dt))
    elif accel == 1:
        out.update(accel_bias=1)
    else:
        out.update(diff_momentum=1, diff_half_window=4)
    return out


@pytest.mark.parametrize("method,accel", [(1, 1), (2, 1), (2, 2)])
@pytest.mark.parametrize("scale,dt", [(1.0, 0.1), (3.0, 0.05)])
def test_profile_sets_the_documented_options(method, accel, scale, dt):
    got = profile_options({"method": method, "accel_source": accel,
                           **{**sensors(scale), "noise_dt": dt}})
    want = expected(method, accel, scale, dt)
    base = default_options()
    for key, value in want.items():
        assert np.allclose(got[key], value, rtol=1e-15, atol=0), (key, got[key], value)
    # nothing else moves: the row weights stay unit (measured: no effect with the paper solver)
    untouched = set(base) - set(want) - {"method", "accel_source", "noise_profile",
                                          "noise_scale", "noise", "noise_dt"}
    for key in untouched:
        assert got[key] == base[key], key


def test_a_users_setting_wins_and_profile_0_reads_no_sensor():
    got = profile_options({"method": 1, "corr_lags": 7, "momentum_window": 2.0,
                           **sensors()})
    assert got["corr_lags"] == 7 and got["momentum_window"] == 2.0
    assert got["momentum_point"] == 1                      # the rest still from the profile
    # profile 0: the options as given, whatever the sensors' values
    off = {**sensors(), "noise_profile": 0, "noise_scale": 3.0}
    got = profile_options(off)
    base = default_options()
    assert got["sd_thrust_scale"] == base["sd_thrust_scale"] == 0.0
    assert got["signal_sd"] == base["signal_sd"]
    assert got["information"] == base["information"] == 0
    # ... but a value outside its declared range (the FMU's min / max) is refused either way
    with pytest.raises(ValueError, match=r"noise\.scale"):
        profile_options({**off, "noise_scale": float("nan")})


def test_information_filter_needs_white_noise_and_the_profile():
    """With noise.scale 0 (ideal sensors) the profile leaves the information filter off (2: no
    noise to weigh the rows by); ident.information = 1 without the profile is refused."""
    assert profile_options({**sensors(0.0)})["information"] == 2
    assert profile_options({**sensors(), "information": 2})["information"] == 2
    from spacerobot.core.estimator import NativeEstimator
    from spacerobot.robots import scenario
    sc = scenario("spatial", "default")
    with pytest.raises(ValueError, match=r"ident\.information = 1 needs"):
        NativeEstimator(sc.robot, {"guess": sc.guess, "information": 1})
    with pytest.raises(ValueError, match=r"ident\.information = 3 is not one of"):
        NativeEstimator(sc.robot, {"guess": sc.guess, "information": 3})


def test_estimator_noise_settings_are_the_profiles():
    """The Python helper reports what the core's profile sets, by FMU name."""
    s = estimator_noise_settings(method=2, accel_source=2)
    assert s["ident.diff_momentum"] == 1 and s["ident.diff_half_window"] == 4
    assert s["ident.noise.base.v"] == pytest.approx(1e-3, rel=1e-15)
    assert s["ident.noise.base.omega"] == pytest.approx(2e-5 / math.sqrt(0.1), rel=1e-15)
    assert "ident.accel_bias" not in s


@pytest.mark.parametrize("change,name", [
    ({"noise_profile": 2}, "ident.noise_profile"),
    ({"noise_scale": -1.0}, "noise.scale"),
    ({"noise_scale": float("inf")}, "noise.scale"),
    ({"noise_dt": 0.0}, "noise_dt"),
    ({"noise": [float("nan")] * len(SENSOR_MAGNITUDES)}, "noise.gyro.arw"),
    ({"noise_scale": 100.0}, "noise.thrust.scale"),        # 2 % x 100 = 200 % > 100 %
])
def test_bad_profile_values_are_refused_with_the_parameter(change, name):
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        profile_options({**sensors(), **change})
    from spacerobot.core.estimator import NativeEstimator
    from spacerobot.robots import scenario
    sc = scenario("spatial", "default")
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        NativeEstimator(sc.robot, {"guess": sc.guess, **sensors(), **change})


def test_estimator_fmu_parameters_carry_the_sensors_names_units_and_defaults():
    from spacerobot.robots import scenario
    sc = scenario("spatial", "default")
    v = {x.name: x for x in interface.estimator_vars(sc.robot, sc)}
    assert v["ident.noise_profile"].start == 0 and v["ident.noise_profile"].type == "Integer"
    for name in ("noise.scale",) + interface.PROFILE_MAGNITUDES:
        unit, default, _ = NOISE_PARAMETERS[name]
        assert (v[name].unit, v[name].start, v[name].causality) == (unit, default, "parameter")
    assert v["ident.information"].start == 0 and v["ident.information"].type == "Integer"
    # the sensors FMU's magnitudes the profile does not read are not estimator parameters
    assert "noise.gyro.rrw" not in v and "noise.accel.bias" not in v


def test_realistic_set_binds_the_profile(tmp_path):
    from spacerobot.system.ssd import build_system
    built = build_system("spatial", tmp_path / "s", sensors=True)
    with zipfile.ZipFile(built["ssp"]) as z:
        text = z.read("resources/estimator/realistic.ssv").decode()
        ideal = z.read("resources/estimator/ideal.ssv").decode()
    for name, value in (("ident.noise_profile", "1"), ("method", "2"), ("accel_source", "2"),
                        ("noise.scale", "1")):
        assert f'name="{name}"' in text
        chunk = text.split(f'name="{name}"')[1].split("</ssv:Parameter>")[0]
        assert f'value="{value}' in chunk, (name, chunk)
    chunk = ideal.split('name="ident.noise_profile"')[1].split("</ssv:Parameter>")[0]
    assert 'value="0"' in chunk


def _run_sensors(tmp_path, extra=()):
    """``spacerobot run --robot spatial --sensors`` for 120 s; the printed table's errors."""
    out = subprocess.run([sys.executable, "-m", "spacerobot", "run", "--robot", "spatial",
                          "--sensors", "--stop-time", "120", "--no-progress", "--build-dir",
                          str(tmp_path / "b"), "--out", str(tmp_path / f"r{len(extra)}.csv"),
                          *extra], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stderr
    errors = {}
    for line in out.stdout.splitlines():
        f = line.split()
        if len(f) >= 5 and f[0] in interface.ESTIMATE_NAMES and f[4] == "%":
            errors[f[0]] = float(f[3]) / 100.0
    assert len(errors) == 20, out.stdout
    return out.stdout, errors


@pytest.mark.slow
def test_sensors_run_with_no_setting_gives_usable_inertias(tmp_path):
    """The issue's measurement: with realistic sensors the estimator's defaults gave inertia
    errors of 1e4 % and more. With the realistic set's profile (no --set: the information
    filter reports), every estimate of the default scenario within 0.5 % (error/scale) after
    120 s (measured: 0.025 % worst; 3.4 % at 300 s with the filter off); the defaults
    (profile 0, the momentum method, the paper's equations) far off on the same run."""
    text, errors = _run_sensors(tmp_path)
    assert "method force" in text and "accelerations differenced" in text
    assert max(errors.values()) < 0.005, errors
    _, plain = _run_sensors(tmp_path, ["--method", "momentum", "--set",
                                       "estimator.ident.noise_profile=0"])
    assert max(plain.values()) > 1.0, plain                # more than 100 % off


@pytest.mark.slow
def test_montecarlo_sensors_case_runs_the_preset(tmp_path):
    """One SensorsCase through the system with the sensors (no Dask): the overrides carry the
    sensors' seed and scale to both FMUs, and the row's calibration column is filled."""
    from spacerobot.system.montecarlo import SensorsCase, build_sensors_system, run_case
    case = SensorsCase("spatial", 0, 5, "force", "closed", 60.0, "differenced", noise_scale=0.5)
    ov = case.fmi_overrides()
    assert ov["sensors.noise.scale"] == ov["estimator.noise.scale"] == 0.5
    assert ov["sensors.seed"] == case.sensors_seed != SensorsCase(
        "spatial", 1, 5, "force", "closed", 60.0, "differenced").sensors_seed
    assert case.id != SensorsCase("spatial", 0, 5, "force", "closed", 60.0, "differenced").id
    ssp = build_sensors_system("spatial", tmp_path / "s")["ssp"]
    row = run_case(case, str(ssp))
    assert row["status"] == "ok", row["error"]
    assert 0.0 <= row["within2sd"] <= 1.0
    assert row["worst_error"] < 0.2                        # a usable answer after 60 s


@pytest.mark.slow
def test_estimator_fmu_refuses_a_bad_profile_value(tmp_path):
    """Through the native estimator FMU (the SSP with the sensors): a negative noise.scale is
    refused at initialisation with the parameter's name; nothing runs."""
    out = subprocess.run([sys.executable, "-m", "spacerobot", "run", "--robot", "spatial",
                          "--sensors", "--stop-time", "1", "--no-progress", "--build-dir",
                          str(tmp_path / "b"), "--out", str(tmp_path / "r.csv"), "--set",
                          "estimator.noise.scale=-1"], capture_output=True, text=True,
                         cwd=tmp_path, timeout=600)
    assert out.returncode != 0
    assert "noise.scale must be a finite number in [0, 1e6], got -1" in out.stderr, out.stderr


@pytest.mark.slow
def test_running_the_sensors_ssp_file_uses_its_bound_set(tmp_path):
    """``spacerobot run <robot>_sensors.ssp``: the set its SSD binds (realistic, with its noise
    profile, force method, differenced accelerations), as any SSP tool runs it; the header and
    the result's name say so."""
    from spacerobot.system.ssd import build_system, has_sensors
    ssp = build_system("spatial", tmp_path / "s", sensors=True)["ssp"]
    assert has_sensors(ssp) and not has_sensors(build_system("spatial", tmp_path / "p")["ssp"])
    out = subprocess.run([sys.executable, "-m", "spacerobot", "run", str(ssp), "--stop-time", "2",
                          "--no-progress"], capture_output=True, text=True, cwd=tmp_path,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert ("parameter set realistic, method force, solver paper, accelerations differenced"
            in out.stdout), out.stdout
    assert (tmp_path / "results" / "spatial_sensors-realistic-force-differenced-paper-t2.csv"
            ).is_file(), sorted(p.name for p in (tmp_path / "results").iterdir())
