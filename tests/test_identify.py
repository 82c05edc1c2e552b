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


#: round-off in the standard deviations of noise-free runs, relative to the estimate's scale: the
#: drift tracker amplifies a 1-ulp difference (e.g. of a sine) to up to 1.1e-5 of the error scale
#: (measured, tests/test_native_estimator.py PORTABLE_TRIG)
SD_ROUNDOFF = 5e-5


def _assert_replay_equals_live(live, replay, rtol=1e-9, sd_rtol=1e-9):
    """Live row k+1 (the FMU's outputs after consuming the sample of row k) = replay row k.

    The live estimator is the native FMU, the replay the library's Identifier: the same C
    core (the FMU's binary and the library built from the same sources, possibly by another
    compiler), compared within the tolerances of two implementations all the same.
    ``sd_rtol``: standard deviations of estimates the data have observed (an sd above 1e6 times
    the estimate is the unobserved floor, which bounds nothing and follows round-off), plus
    :data:`SD_ROUNDOFF` of the estimate's scale."""
    outs = [c[len("estimator."):] for c in live if c.startswith("estimator.")
            and c[len("estimator."):] in replay]
    assert set(ESTIMATE_NAMES) <= set(outs) and "sd.target.m" in outs and "diag.samples" in outs
    for n in outs:
        a, b = live["estimator." + n][1:], replay[n][:-1]
        if n.startswith(("sd.", "crb.")):     # the information filter's bound: as the sd
            est = np.maximum(1.0, np.abs(live["estimator." + n.split(".", 1)[1]][1:]))
            seen = np.abs(a) <= 1e6 * est
            tol = sd_rtol * np.abs(a) + SD_ROUNDOFF * est
            assert np.all(np.abs(a - b)[seen] <= tol[seen]), n
        else:
            assert np.all(np.abs(a - b) <= rtol * np.maximum(1.0, np.abs(a))), n


#: the estimator's noise model (docs/identification.md, section 6), not its defaults
NOISE_MODEL = {"ident.sd_row.force_lin": 5.0, "ident.sd_row.force_ang": 3.0,
               "ident.diff_half_window": 2, "ident.corr_lags": 20}
#: (estimates, sd) tolerances of the native FMU against the Python core with the noise model:
#: the Savitzky-Golay weights (m = 2) and the autocorrelation sums are added in another order
#: (measured: 2.8e-9 on estimates, 1.6e-4 on sd; tests/test_native_estimator.py)
NOISE_MODEL_TOL = (1e-8, 1e-3)


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
    # the estimator as the live run had it: the set's bound settings (the realistic set's noise
    # profile) under the overrides
    from spacerobot.robots import PARAMETER_SETS
    bound = {k: v for k, v in PARAMETER_SETS["planar"][pset].estimator
             if k not in ("method", "accel_source")}
    sets = [a for k, v in {**bound, **model}.items() for a in ("--set", f"{k}={v}")]
    assert main(["identify", str(csv), "--robot", "planar", "--method", method, "--accel",
                 accel, "--out", str(out)] + sets) == 0
    printed = capsys.readouterr().out
    assert "target.m" in printed and "CSV: " in printed
    live, replay = read_csv(csv), read_csv(out)
    _assert_replay_equals_live(live, replay, *(NOISE_MODEL_TOL if model else ()))
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


# ---------------------------------------------------------------------------------------------
# issue #28: what the docs promise an integrator, and readable outputs
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def excited_run(planar_systems, tmp_path_factory):
    """A recorded 3 s planar run (excited set) and its data."""
    csv = tmp_path_factory.mktemp("excited") / "run.csv"
    run_ssp(planar_systems["two"]["ssp"], parameter_set="excited", stop_time=3.0, csv_path=csv,
            progress=False)
    return csv, read_csv(csv)


def test_output_carries_truth_and_the_verdict_is_printed(excited_run, tmp_path, capsys):
    """The result CSV holds the telemetry's truth per sample (so that spacerobot plot compares
    with it), and the printed table has the error metric in its header and the estimator's
    identified / physical verdict of the last row."""
    csv, live = excited_run
    out = tmp_path / "est.csv"
    assert main(["identify", str(csv), "--robot", "planar", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    est = read_csv(out)
    for n in ESTIMATE_NAMES:
        assert np.array_equal(est["truth." + n], live["plant." + n]), n
    assert printed.splitlines()[1].split()[3] == "error/scale"
    flags = {f: est[f"diag.{f}.{b}"][-1] for f in ("identified", "physical")
             for b in ("target",)}
    word = {1.0: "yes", 0.0: "no"}
    assert f"target {word[flags['identified']]}" in printed.split(
        "identified (sd below ident.sd_rel): ")[1].splitlines()[0]
    assert f"target {word[flags['physical']]}" in printed.split(
        "real body as estimated (no projection): ")[1].splitlines()[0]


def _relative_difference(a: dict, b: dict) -> float:
    from spacerobot.interface import error_scale
    va = np.array([a[n][-1] for n in ESTIMATE_NAMES])
    vb = np.array([b[n][-1] for n in ESTIMATE_NAMES])
    return float(np.max(np.abs(va - vb) / error_scale(va)))


@pytest.mark.parametrize("settings", [
    {"method": 1},                                             # eqs. 11/16 against the first
    {"method": 1, "solver": 2},
    {"method": 1, "ident.momentum_window": 0.5, "ident.momentum_point": 1},
    {"method": 2, "accel_source": 2, "ident.diff_momentum": 1, "ident.diff_half_window": 2}])
def test_impulses_from_any_fixed_instant_give_the_same_estimates(excited_run, settings):
    """docs: thrust.J / thrust.H may be counted from any fixed instant (the plant: t = 0,
    telemetry: e.g. the first sample): a constant offset changes no estimate (to 1e-9 of the
    error scale, round-off of the offset's size) in every form that uses the impulses."""
    from spacerobot.system.identify import estimator_parameters, identify, read_telemetry
    csv, _ = excited_run
    time, groups = read_telemetry(csv, ROBOTS["planar"].n_joints)
    shifted = dict(groups, J=groups["J"] + np.array([12.5, -40.0, 3.0]),
                   H=groups["H"] + np.array([-300.0, 25.0, 170.0]))
    values = estimator_parameters("planar", settings)
    a = identify(time, groups, "planar", values)
    b = identify(time, shifted, "planar", values)
    assert a["diag.samples"][-1] > 10
    assert _relative_difference(a, b) < 1e-9
    assert _relative_difference(a, identify(time, dict(groups, J=2 * groups["J"]), "planar",
                                            values)) > 1e-3        # the test can fail


def test_estimator_never_reads_the_base_inertial_of_the_urdf(excited_run, tmp_path):
    """docs: the base <inertial> is only a placeholder for the estimator (the plant's truth):
    the same telemetry identified with a URDF whose base mass, CoM and inertia are wrong gives
    the same estimates, bit for bit; a wrong arm link mass does change them."""
    import re as _re
    from importlib import resources
    from spacerobot.robots import get_robot, robot_spec
    from spacerobot.system.identify import estimator_parameters, identify, read_telemetry
    csv, _ = excited_run
    text = (resources.files("spacerobot") / "data" / "robots" / "planar.urdf").read_text()
    base = _re.compile(r'(<link name="base">\s*)<inertial>.*?</inertial>', _re.S)
    assert base.search(text)
    wrong_base = base.sub(r'\1<inertial><origin xyz="0.3 -0.2 0.1"/><mass value="123.0"/>'
                          r'<inertia ixx="7" iyy="9" izz="11" ixy="0.5" ixz="0" iyz="0"/>'
                          r'</inertial>', text, count=1)
    wrong_arm = text.replace('<mass value="40.0"/>', '<mass value="41.0"/>', 1)
    keys = []
    for name, body in (("wrong_base", wrong_base), ("wrong_arm", wrong_arm)):
        assert body != text
        (tmp_path / f"{name}.urdf").write_text(body)
        keys.append(robot_spec(str(tmp_path / f"{name}.urdf")))
    assert get_robot(keys[0]).base.mass == 123.0 != get_robot("planar").base.mass
    time, groups = read_telemetry(csv, ROBOTS["planar"].n_joints)
    a = identify(time, groups, "planar", estimator_parameters("planar"))
    b = identify(time, groups, keys[0], estimator_parameters(keys[0]))
    for n in list(ESTIMATE_NAMES) + ["sd.target.m", "diag.identified.target"]:
        assert np.array_equal(a[n], b[n]), n
    c = identify(time, groups, keys[1], estimator_parameters(keys[1]))
    assert _relative_difference(a, c) > 1e-4                   # the arm is read


def test_default_output_is_named_by_the_settings(excited_run, tmp_path, capsys, monkeypatch):
    """spacerobot identify without --out: the result beside the telemetry, named by method,
    accelerations, solver and --set overrides (with or without the estimator. prefix the
    same); a second identification with the same settings says it replaces the file."""
    import shutil
    csv = tmp_path / "run.csv"
    shutil.copy(excited_run[0], csv)
    args = ["identify", str(csv), "--robot", "planar", "--method", "force"]
    assert main(args + ["--set", "lambda=0.999"]) == 0
    first = tmp_path / "run-identified-force-measured-paper-lambda=0.999.csv"
    assert first.is_file()
    assert capsys.readouterr().err == ""
    assert main(args + ["--set", "estimator.lambda=0.999"]) == 0
    assert capsys.readouterr().err.splitlines() == [
        f"spacerobot identify: {first} exists: this run replaces it"]
    assert main(args) == 0
    assert (tmp_path / "run-identified-force-measured-paper.csv").is_file()
    # the estimator runs the native core: nothing to compile, nothing to announce
    capsys.readouterr()
    assert main(args + ["--out", str(tmp_path / "again.csv")]) == 0
    assert capsys.readouterr().err == ""
