"""The information filter on a weakly excited, fast-drifting rigid spacecraft (docs/
identification.md, "Weak excitation"): the spatial robot without wings or slosh, with the
motion of the flexible sets (``robots.FLEXIBLE_MOTION``: 0.37 m/s drift, 0.06 rad/s) and the
plant's excitation at amplitude A (attitude and joints, rad), 300 s through the sensors'
realistic defaults with the noise profile (its information filter reports), judged against
the plant's truth:

* A = 0.3 (the plant's default amplitude), seed 2: no misfit, within 0.5 % and at least 18 of
  the 20 estimates within 2 reported sd (measured 0.10 %, 20);
* A = 0.2, seeds 0-3 (80 estimates): at least 90 % within 2 sd, every estimate within 1.5 %,
  no flag (measured 80 of 80, at most 0.55 %; at 0.15 rad, not run here, 79 of 80 and
  0.86 %). Before the errors-in-variables correction stopped counting the navigation noises'
  product twice the exact correction overshot here: 9-19 of 20 within 2 sd per run, errors up
  to 4.2 sd (``tests/test_information.py::test_compensation_bias_small_under_a_fast_drift``
  checks the correction itself);
* A = 0.1 (the flexible sets' own), seeds 1 and 2 (seed 1 the worst covered without the
  errors-in-variables term below): no misfit, no body flagged, every
  estimate within 2.5 % and at least 36 of the 40 within 2 sd (measured 1.77 and 1.23 %, 40
  of 40). Before the model-fit test's residuals were taken at the compensated estimate after
  the replay, its Ljung-Box Q/L grew to 50-54 by 300 s (the innovations of a running,
  uncompensated estimate) and a false misfit held the thrust errors: 15-36 % off, covered;
  before the sds carried ``ident.eiv_uncertainty``'s share of the errors-in-variables
  correction (up to 31 % of an estimate here), seed 1 had 11 of 20 within 2 sd;
* a servicer the flexible parts were not developed on (tests/data/arm5.urdf: a 900 kg hub with a
  5-joint arm) with the `slosh` set's masses at 0.5 / 0.58 Hz, the sets' motion, sensor seed 1
  (of seeds 0-3 the one the sds did not cover without that term): no body flagged, every
  estimate within 3 % of the composite truth and at least 18 of 20 within 2 sd (measured 2.08 %,
  20). The model-fit test does not see this slosh (its residuals at the compensated estimate,
  Q/L 1.47, are as white as rigid runs', 0.8-1.8); the sds cover it through the
  errors-in-variables term (without it 12 of 20). Before, the innovations' growing colour
  declared a misfit at 253 s, and the held thrust errors left the estimates 42 % off, covered.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from conftest import ARM5_URDF
from spacerobot.core.plant import NativePlant
from spacerobot.core.sample import sample_length
from spacerobot.interface import relative_errors
from spacerobot.robots import Excitation, parameter_set_scenario
from spacerobot.sensors import SensorSuite
from spacerobot.system.identify import estimator_parameters, identifier_of

#: 300 s runs of the plant and the information filter: seconds each
pytestmark = pytest.mark.slow

DT = 0.1
T_END = 300.0
SEED = 2


def _rigid(amplitude: float):
    """(robot, scenario): the spatial robot without wings or slosh, the flexible sets' motion,
    the excitation at ``amplitude`` (attitude and joints, rad)."""
    sc = parameter_set_scenario("spatial", "wings")
    return "spatial", replace(sc, flex=replace(sc.flex, n=0),
                              excitation=Excitation(att_max=amplitude, q_max=amplitude))


def _held_out_slosh():
    """(robot, scenario): the held-out servicer with the `slosh` set's two masses at 0.5 /
    0.58 Hz."""
    sc = parameter_set_scenario(ARM5_URDF, "slosh")
    modes = tuple(replace(m, f=f) for m, f in zip(sc.slosh.modes, (0.5, 0.58)))
    return ARM5_URDF, replace(sc, slosh=replace(sc.slosh, modes=modes + sc.slosh.modes[2:]))


def _run(robot: str, sc, seed: int = SEED) -> dict:
    """300 s of ``sc`` (of ``robot``) through the sensors (``seed``), the information filter
    reporting; judged against the plant's (composite) truth; ``fits`` the reported
    ``diag.model_fit`` at every sample."""
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    n = sample_length(plant.n)
    ident = identifier_of(robot, estimator_parameters(robot, {
        "method": 1, "solver": 2, "ident.noise_profile": 1, "noise.scale": 1.0}), DT)
    suite = SensorSuite(plant.n, scale=1.0, seed=seed, dt=DT)
    flagged = misfit = False
    fits = []
    for k in range(int(round(T_END / DT)) + 1):
        if k:
            plant.advance(DT)
        ident.update(k * DT, suite.update(suite.sample(plant.output_vector()[:n]), DT))
        rep = ident.core.report()
        flagged |= rep["identified"]["base"] or rep["identified"]["target"]
        misfit |= rep["misfit"]
        fits.append(rep["model_fit"])
    b = plant.base_now()
    truth = np.r_[b.mass, b.com, b.inertia, sc.target.mass, sc.target.com, sc.target.inertia]
    est, sd = np.asarray(ident.vector()), np.asarray(ident.std())
    out = {"worst": float(relative_errors(est, truth).max()),
           "within": int(np.sum(np.abs(est - truth) <= 2.0 * sd)),
           "flagged": flagged, "misfit": misfit, "fit": rep["model_fit"]}
    print(f"{sc.name}: {out}")
    return {**out, "fits": np.array(fits)}


@pytest.fixture(scope="module")
def runs():
    """(amplitude, seed) -> the rigid spacecraft's run at that excitation amplitude"""
    cache = {}

    def get(amplitude, seed=SEED):
        if (amplitude, seed) not in cache:
            cache[amplitude, seed] = _run(*_rigid(amplitude), seed=seed)
        return cache[amplitude, seed]
    return get


def test_default_amplitude_is_accurate_and_covered(runs):
    r = runs(0.3)
    assert r["worst"] < 5e-3 and r["within"] >= 18 and not r["misfit"]


def test_weak_excitation_is_never_flagged_accurate_and_covered(runs):
    rs = [runs(0.1, seed) for seed in (1, 2)]
    assert not any(r["flagged"] for r in rs)
    assert sum(r["within"] for r in rs) >= 36, [r["within"] for r in rs]
    assert max(r["worst"] for r in rs) < 0.025, [r["worst"] for r in rs]


def test_weak_excitation_no_false_misfit(runs):
    assert not any(runs(0.1, seed)["misfit"] for seed in (1, 2))


def test_moderate_excitation_sd_cover_the_errors(runs):
    rs = [runs(0.2, seed) for seed in range(4)]
    assert sum(r["within"] for r in rs) >= 72, [r["within"] for r in rs]
    assert max(r["worst"] for r in rs) < 0.015 and not any(r["flagged"] for r in rs)


def test_held_out_servicer_slosh_accurate_and_covered():
    r = _run(*_held_out_slosh(), seed=1)
    assert not r["flagged"] and r["within"] >= 18 and r["worst"] < 0.03, r


def test_whiteness_restarts_at_the_replay(runs):
    """The model-fit test reads the innovations up to the filter's replay (sample 600) and,
    restarted there, the residuals at the compensated estimate: ``diag.model_fit`` (its
    Ljung-Box Q/L, 0 before 2 ident.fit_lags = 100 rows) is positive before the replay, 0 for
    the 99 samples after it, and on this rigid spacecraft about 1 once it counts again (white
    residuals: below 2 over the next 10 s)."""
    fit = runs(0.3)["fits"]
    assert fit[599] > 0.0
    assert np.all(fit[600:700] == 0.0), fit[600:700]
    assert np.all((fit[700:801] > 0.0) & (fit[700:801] < 2.0)), fit[700:801].max()
