"""The estimator where the rigid model does not fit (docs/identification.md, "When the rigid
model does not fit"): the plant's flexible targets (``wings``, ``slosh``, ``flexible``: hinged
solar wings and propellant slosh on the spatial robot's base) run end to end through the FMUs
and judged against the plant's composite rigid truth (``truth.base.*``: base + panels at rest +
slosh masses at equilibrium), and the rigid spacecraft for the test's other side: the
model-fit test says misfit on every flexible run and never on a rigid one, no body is flagged
under misfit, the standard deviations cover the errors (>= 90 % of the estimates within 2 sd
over the cases), the masses are not shrunk with the sensors (the thrust scale held at its prior
where the residuals are coloured; where the thrust scale alone tells the misfit, the slosh, it
stays estimated and the sds carry the held alternative: 3.1 % off).
"""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot import run_ssp
from spacerobot.core.estimator import NativeEstimator
from spacerobot.interface import ESTIMATE_NAMES, error_scale
from spacerobot.robots import scenario
from spacerobot.system import ssd
from spacerobot.system.codes import estimator_overrides
from spacerobot.system.runner import format_results

STOP = 300.0
#: the sensors' runs: the estimator with the sensors' noise model (the information filter)
PROFILE = {"estimator.ident.noise_profile": 1}
#: the masses with the sensors: within 3 % of the composite (measured 0.2-2.5 %; with the
#: scale free in every case they fell to 0.0001-0.77 of it)
MASS_TOL_SENSORS = 0.03
#: noise-free, momentum method: within 0.5 % (measured 0.00-0.1 %)
MASS_TOL_MOMENTUM = 0.005


@pytest.fixture(scope="module")
def systems(tmp_path_factory, spatial_fmus) -> dict:
    """the SSPs without and with the sensors, and the runs so far (one 300 s run serves
    every test that asks for its case)"""
    root = tmp_path_factory.mktemp("misfit")
    return {False: ssd.build_system("spatial", root / "plain", fmus=spatial_fmus)["ssp"],
            True: ssd.build_system("spatial", root / "sensors", fmus=spatial_fmus,
                                   sensors=True)["ssp"], "runs": {}}


def _run(systems, target: str, method: str, sensors: bool, **more) -> dict:
    key = (target, method, sensors, tuple(sorted(more.items())))
    if key not in systems["runs"]:
        systems["runs"][key] = _simulate(systems, target, method, sensors, **more)
    return systems["runs"][key]


def _simulate(systems, target: str, method: str, sensors: bool, **more) -> dict:
    over = estimator_overrides(method, "measured", None)
    if sensors:
        over.update(PROFILE)
    over.update(more)
    return _scored(run_ssp(systems[sensors], parameter_set=target, stop_time=STOP,
                           overrides=over, progress=False))


#: how the estimator FMU's warning and the run's verdict name each diag.misfit_cause
CAUSE_PHRASE = {1: "the rigid model does not fit the samples",
                2: "the residuals are white but larger than the noise model's",
                3: "a thrust scale factor is estimated beyond its prior"}
VERDICT_PHRASE = {1: "the rigid model does not fit", 2: "the noise.* values are too small",
                  3: "a thrust scale beyond its prior"}


def _time_of(message: str) -> float:
    """The time [s] an estimator log message starts with ("t = 60 s: ...")."""
    return float(message.split(" s:")[0][4:])


def _scored(res) -> dict:
    """A run's final estimates against the truth and what the estimator said of its fit."""
    d = res.data
    est = np.array([res.final[n] for n in ESTIMATE_NAMES])
    truth = np.array([res.truth[n] for n in ESTIMATE_NAMES])
    sd = np.array([d["estimator.sd." + n][-1] for n in ESTIMATE_NAMES])
    err = np.abs(est - truth)
    scale = np.asarray(error_scale(truth))
    return {"err": err, "rel": err / scale, "scale": scale, "sd": sd, "est": est,
            "truth": truth, "misfit": d["estimator.diag.misfit"],
            "flags": np.maximum(d["estimator.diag.identified.base"],
                                d["estimator.diag.identified.target"]),
            "fit": d["estimator.diag.model_fit"], "time": res.time,
            "told": [_time_of(m[3]) for m in res.log
                     if m[0] == "estimator" and "diag.misfit = 1" in m[3]],
            "said": [m[3] for m in res.log if m[0] == "estimator" and "diag.misfit" in m[3]],
            "cause": np.rint(d["estimator.diag.misfit_cause"]).astype(int),
            "verdict": format_results(res)}


def _told_as_recorded(r: dict, label: str) -> None:
    """The estimator FMU's warning comes once at each onset of diag.misfit, at the sample
    that set it (the step from t to t + h sets the output recorded at t + h), and the run's
    verdict says so where the run ends in a misfit."""
    m = np.asarray(r["misfit"]) > 0.5
    onsets = np.flatnonzero(m[1:] & ~m[:-1]) + 1
    if m[0]:
        onsets = np.r_[0, onsets]
    assert len(r["told"]) == len(onsets), (label, r["told"], r["time"][onsets])
    h = r["time"][1] - r["time"][0]
    assert np.allclose(r["told"], r["time"][onsets] - h, atol=1e-6), label
    said = "the model-fit test failed (diag.misfit 1 from t =" in r["verdict"]
    assert said == bool(m[-1]), (label, r["verdict"])
    # diag.misfit_cause: nonzero exactly while diag.misfit is 1; each warning (an onset or a
    # change of cause) names the cause recorded after its step, and so does the verdict
    cause = r["cause"]
    assert np.array_equal(cause != 0, m) and set(cause) <= {0, 1, 2, 3}, label
    warned = [msg for msg in r["said"] if "diag.misfit = 0" not in msg]
    changes = int(cause[0] != 0) + int(np.count_nonzero((cause[1:] != cause[:-1])
                                                        & (cause[1:] != 0)))
    assert len(warned) == changes, (label, warned, changes)
    for msg in warned:
        k = int(np.argmin(np.abs(r["time"] - _time_of(msg) - h)))
        assert CAUSE_PHRASE[cause[k]] in msg, (label, r["time"][k], cause[k], msg)
    if m[-1]:
        assert f"its cause (diag.misfit_cause): {VERDICT_PHRASE[cause[-1]]}" in r["verdict"], \
            (label, r["verdict"])


def _judge(cases: dict, systems) -> None:
    """Every case: misfit at the end, no flag ever, masses as stated; over the cases >= 90 %
    of the estimates within 2 sd of the composite truth."""
    within = total = 0
    for (target, method, sensors), r in cases.items():
        label = f"{target} {method} sensors={sensors}"
        assert r["misfit"][-1] == 1, label
        _told_as_recorded(r, label)
        assert r["flags"].max() == 0, label
        inside = int(np.sum(r["err"] <= 2.0 * r["sd"]))
        within += inside
        total += len(ESTIMATE_NAMES)
        # no case's sds fail wholesale (the aggregate is the figure)
        assert inside >= 14, (label, inside, r["err"] / r["sd"])
        mass = r["est"][[0, 10]] / r["truth"][[0, 10]]
        if sensors:
            assert np.all(np.abs(mass - 1.0) < MASS_TOL_SENSORS), (label, mass)
        elif method == "momentum":
            assert np.all(np.abs(mass - 1.0) < MASS_TOL_MOMENTUM), (label, mass)
    assert within >= 0.9 * total, (within, total)


FAST = [("flexible", "momentum", False), ("wings", "force", False),
        ("slosh", "momentum", True), ("flexible", "force", True)]
ALL = [(t, m, s) for t in ("wings", "slosh", "flexible") for m in ("momentum", "force")
       for s in (False, True)]


def test_flexible_spacecraft_misfit_no_flag_and_covered(systems):
    _judge({c: _run(systems, *c) for c in FAST}, systems)


@pytest.mark.slow
def test_every_flexible_case_misfit_no_flag_and_covered(systems):
    _judge({c: _run(systems, *c) for c in ALL}, systems)


def test_slosh_thrust_scale_misfit_keeps_the_thrust_estimated(systems):
    """The issue's slosh through the sensors: the thrust scale alone tells the misfit (white
    residuals), so the thrust errors stay estimated and the sds carry the difference to the
    estimates with them held: worst error below 4 % (measured 3.11 %; with the thrust held,
    as a coloured misfit is answered, 17.1 %), >= 18 of 20 within 2 sd (measured 19), the
    cause told once in the log, no flag."""
    r = _run(systems, "slosh", "momentum", True)
    assert r["rel"].max() < 0.04, r["rel"].max()
    assert int(np.sum(r["err"] <= 2.0 * r["sd"])) >= 18
    assert r["flags"].max() == 0 and r["misfit"][-1] == 1
    assert len(r["said"]) == 1 and "a thrust scale factor is estimated beyond its prior" in \
        r["said"][0], r["said"]
    assert r["cause"][-1] == 3
    _told_as_recorded(r, "slosh sensors")


def test_rigid_body_with_its_thrust_miscalibrated_keeps_the_thrust_estimated(systems):
    """The rigid spacecraft (the realistic set, 300 s) whose thrust scale error is drawn at 5
    times the estimator's prior (the sensors' noise.thrust.scale 0.1 against 0.02): the
    thrust scale tells a misfit with white residuals (cause thrust, logged once), the thrust
    errors stay estimated: every estimate within 0.5 % (measured 0.032 %; on the previous tree,
    held and replayed with the model error: 1120 % off, in-process), >= 18 of 20 within
    2 sd (measured 20; the sds carry the held answer, up to 22 % of the scale), no flag."""
    r = _scored(run_ssp(systems[True], parameter_set="realistic", stop_time=STOP,
                        overrides={"sensors.noise.thrust.scale": 0.1}, progress=False))
    assert r["rel"].max() < 5e-3, r["rel"].max()
    assert int(np.sum(r["err"] <= 2.0 * r["sd"])) >= 18
    # the sds are the held answer's distance (22 % of the scale at most on this seed): wide,
    # but not unbounded
    assert (r["sd"] / r["scale"]).max() < 0.5
    assert np.asarray(r["misfit"])[-1] == 1
    assert r["flags"].max() == 0
    assert len(r["said"]) == 1 and "a thrust scale factor is estimated beyond its prior" in \
        r["said"][0], r["said"]
    assert r["cause"][-1] == 3
    _told_as_recorded(r, "thrust miscalibrated")


def test_held_out_servicer_slosh_cause_change_told(tmp_path):
    """The held-out servicer (tests/data/arm5.urdf) with the issue's slosh through the
    sensors, from the docs' wiring (its own SSP): the thrust scale tells the misfit at the
    replay (60 s), then, with the thrust errors estimated, the residuals turn coloured and the
    cause becomes the rigid model's while diag.misfit stays 1 (measured at 141.4 s): the FMU
    logs both, the second as a change of cause, and nothing else about the misfit; no flag;
    from then on the rigid band reports (diag.band, on by the profile): every estimate within
    4 % (measured 3.0 %; the held filter's, with the band off, 31.4 %), >= 18 of 20 within
    2 sd (measured 20)."""
    from conftest import ARM5_URDF
    ssp = ssd.build_system(ARM5_URDF, tmp_path / "arm5", sensors=True)["ssp"]
    over = estimator_overrides("momentum", "measured", None)
    over.update(PROFILE)
    r = _scored(run_ssp(ssp, parameter_set="slosh", stop_time=STOP, overrides=over,
                        progress=False))
    said = r["said"]
    assert len(said) == 2, said
    assert said[0].startswith("t = 60 s: a thrust scale factor is estimated beyond its prior")
    assert "the rigid model does not fit the samples (diag.misfit stays 1, its cause " \
        "changed)" in said[1]
    changed_at = _time_of(said[1])
    assert 60.0 < changed_at < STOP
    assert np.all(np.asarray(r["misfit"])[r["time"] > 61.0] == 1)
    assert r["flags"].max() == 0
    assert int(np.sum(r["err"] <= 2.0 * r["sd"])) >= 18
    assert r["rel"].max() < 0.04
    # diag.misfit_cause: thrust (3) from the replay, the rigid model's (1) at the end
    assert r["cause"][np.searchsorted(r["time"], 61.0)] == 3 and r["cause"][-1] == 1
    _told_as_recorded(r, "arm5 slosh")


@pytest.mark.slow
def test_a_later_model_misfit_stays():
    """The held-out servicer's slosh through the sensors (seed 0, 300 s, in-process: the
    momentum method, the joint solver's options and the noise profile, as
    benchmarks/flexible.py): the thrust scale tells the misfit at the replay (60 s), the
    residuals turn coloured about 141 s and the rigid model's misfit then stays: the cause
    changes exactly twice (on the previous tree it flipped between thrust and model 8 times
    from 141.6 to 147.5 s as the whiteness hovered about its threshold), no flag."""
    from conftest import ARM5_URDF
    from oracles.samples import fmu_identifier, parameter_set_samples
    from spacerobot.sensors import SensorSuite
    dt = 0.1
    sc, xs, _ = parameter_set_samples(ARM5_URDF, "slosh", STOP, dt)
    ident = fmu_identifier(sc, dt, {"method": 1, "solver": 2, "ident.excite_adapt": 2,
                                    "ident.noise_profile": 1, "noise.scale": 1.0})
    suite = SensorSuite(sc.robot.n_joints, scale=1.0, seed=0, dt=dt)
    causes, flagged = [], False
    for k, x in enumerate(xs):
        ident.update(k * dt, suite.update(suite.sample(x), dt))
        rep = ident.core.report()
        causes.append(rep["misfit_cause"])
        flagged |= rep["identified"]["base"] or rep["identified"]["target"]
    changes = [(round(k * dt, 1), causes[k]) for k in range(1, len(causes))
               if causes[k] != causes[k - 1]]
    assert [c for _, c in changes] == ["thrust", "model"], changes
    assert changes[0][0] == pytest.approx(60.0) and 100.0 < changes[1][0] < STOP, changes
    assert not flagged


@pytest.mark.slow
def test_a_held_out_flexible_spacecraft(systems):
    """Wings and slosh of other sizes and frequencies than the sets' (30 kg panels at 0.8 Hz,
    slosh at 0.2 / 0.25 Hz): the same guarantees."""
    more = {"plant.flex.f[1]": 0.8, "plant.flex.f[2]": 0.8, "plant.slosh.f[1]": 0.2,
            "plant.slosh.f[2]": 0.25, "plant.flex.m[1]": 30.0, "plant.flex.m[2]": 30.0}
    _judge({("flexible", m, s): _run(systems, "flexible", m, s, **more)
            for m in ("momentum", "force") for s in (False, True)}, systems)


@pytest.mark.parametrize("sensors", [False, True])
def test_rigid_spacecraft_never_misfit(systems, sensors):
    """The rigid spacecraft: no misfit at any sample, the flags rise, the statistic well
    below its threshold (noise-free the relative residual 1e-4 against 1e-2; with the sensors
    the Ljung-Box Q/L 1.63 at 300 s against 30)."""
    # with the sensors a flag at the default confidence (0.99 for a body's 10 estimates) asks
    # for more than 300 s give on this target: 0.5 (about 2 sd each) shows the gate stays open
    more = {"estimator.ident.flag_confidence": 0.5} if sensors else {}
    r = _run(systems, "default", "momentum", sensors, **more)
    assert r["misfit"].max() == 0
    _told_as_recorded(r, f"default sensors={sensors}")
    assert r["flags"][-1] == 1
    assert r["rel"].max() < (1e-3 if sensors else 1e-5)
    late = r["time"] >= 120.0
    assert r["fit"][late].max() < (2.0 if sensors else 1e-3), r["fit"][late].max()


def test_noise_values_too_small_misfit_without_the_hold(systems):
    """The estimator's navigation position noise set at half the sensors' on the rigid
    spacecraft (the realistic set, 100 s): chi2 passes 2 at the replay with white residuals,
    so diag.misfit is 1 from there on (no flag, the warning told once) but the estimates are
    not held: they stay within 0.5 % of the truth (measured 0.071 %; with the thrust errors
    held and the model error's variances replayed, as a misfit of the rigid model is
    answered, 194 %) and >= 18 of 20 lie within 2 sd (measured 20: the sds carry chi2 - 1 of
    the errors-in-variables correction, which the noise values scale), with every sd below
    0.2 % of its scale."""
    from spacerobot.sensors import default_parameters
    over = {"estimator.noise.nav.r": 0.5 * default_parameters()["nav.r"]}
    res = run_ssp(systems[True], parameter_set="realistic", stop_time=100.0, overrides=over,
                  progress=False)
    r = _scored(res)
    misfit = np.asarray(r["misfit"]) > 0.5
    assert misfit[r["time"] > 61.0].all() and not misfit[r["time"] < 59.0].any()
    assert res.data["estimator.diag.info_chi2"][-1] > 1.5
    assert r["rel"].max() < 5e-3, r["rel"].max()
    assert int(np.sum(r["err"] <= 2.0 * r["sd"])) >= 18
    # covered by sds that stay useful, not by huge ones: every sd below 0.2 % of its scale
    # (measured 0.063 %; 0.042 % with the right noise values)
    assert (r["sd"] / r["scale"]).max() < 2e-3, r["sd"] / r["scale"]
    assert r["flags"].max() == 0
    told = [m[3] for m in res.log if "diag.misfit = 1" in m[3]]
    assert len(told) == 1 and "the noise.* values look too small" in told[0], told
    assert r["cause"][-1] == 2
    _told_as_recorded(r, "nav.r halved")


def test_noise_scale_too_small_is_told_as_noise_not_thrust(systems):
    """The estimator's noise.scale at 0.25 (every noise value and the thrust prior a quarter of
    the sensors'; the realistic set, 100 s): chi2 16.4 with white residuals, and the thrust
    scale beyond its (shrunk) prior too; the cause is the noise values' (chi2 decides before
    the thrust scale), told once: the estimates within 0.5 % (measured 0.058 %), >= 18 of 20
    within 2 sd (measured 20), every sd below 0.2 % of its scale (measured 0.047 %; taken
    as the thrust cause the held answer widened them to 5.9 %), no flag."""
    r = _scored(run_ssp(systems[True], parameter_set="realistic", stop_time=100.0,
                        overrides={"estimator.noise.scale": 0.25}, progress=False))
    assert r["rel"].max() < 5e-3
    assert int(np.sum(r["err"] <= 2.0 * r["sd"])) >= 18
    assert (r["sd"] / r["scale"]).max() < 2e-3, (r["sd"] / r["scale"]).max()
    assert r["flags"].max() == 0
    assert len(r["said"]) == 1 and "the noise.* values look too small" in r["said"][0], \
        r["said"]
    assert r["cause"][-1] == 2
    _told_as_recorded(r, "noise.scale 0.25")


def test_fit_options_are_checked_with_their_names():
    robot = scenario("spatial").robot
    for name, bad in (("ident.fit_lags", 0), ("ident.fit_lags", 101),
                      ("ident.fit_window", 0.0), ("ident.fit_rho_max", 2.0),
                      ("ident.fit_whiteness_max", 0.5), ("ident.fit_chi2_max", float("nan")),
                      ("ident.fit_thrust_max", 0.0), ("ident.fit_bias_k", -1.0),
                      ("ident.fit_bias_k_info", 101.0), ("ident.eiv_uncertainty", -0.1),
                      ("ident.eiv_uncertainty", 1.5)):
        with pytest.raises(ValueError, match=name.replace(".", r"\.")):
            NativeEstimator(robot, {name: bad})
