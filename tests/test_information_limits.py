"""The information filter on a weakly excited, fast-drifting rigid spacecraft (docs/
identification.md, "Weak excitation"): the spatial robot without wings or slosh, with the
motion of the flexible sets (``robots.FLEXIBLE_MOTION``: 0.37 m/s drift, 0.06 rad/s) and the
plant's excitation at amplitude A (attitude and joints, rad), 300 s through the sensors'
realistic defaults with the noise profile (its information filter reports), judged against
the plant's truth:

* A = 0.3 (the plant's default amplitude), seed 2: no misfit, within 0.5 % and at least 18 of
  the 20 estimates within 2 reported sd (measured 0.10 %, 20);
* A = 0.2, seeds 0-3 (80 estimates): at least 90 % within 2 sd, every estimate within 1.5 %,
  no flag (measured 80 of 80, at most 0.55 %; at 0.15 rad, not run here, 76 of 80 and
  0.86 %). Before the errors-in-variables correction stopped counting the navigation noises'
  product twice the exact correction overshot here: 9-19 of 20 within 2 sd per run, errors up
  to 4.2 sd (``tests/test_information.py::test_compensation_bias_small_under_a_fast_drift``
  checks the correction itself);
* A = 0.1 (the flexible sets' own), seed 2: no body flagged and at least 18 within 2 sd
  (measured 20: the model-fit test declares a misfit, so the thrust errors are held and the sd
  widened);
* a known limit, kept as a strict expected failure so that a fix shows: at A = 0.1 that misfit
  is a false one (the spacecraft is rigid; the whitened residuals' Ljung-Box Q/L grows to
  50-54 by 300 s on seeds 0-3 against its threshold 30: the test reads the filter's
  innovations, which follow its running, uncompensated estimate);
* a servicer the flexible parts were not developed on (tests/data/arm5.urdf: a 900 kg hub with
  a 5-joint arm) with the `slosh` set's masses at 0.5 / 0.58 Hz, the sets' motion: the model-fit
  test declares the misfit, no body is flagged and at least 18 of 20 estimates are within 2 sd
  of the composite truth (sensor seed 0; its residuals are coloured, Q/L about 50, at chi2
  0.40-0.46: the whiteness test's former gate, chi2 > 1/2, let it through with the estimates
  8-10 sd off, 3 of 20 within 2 sd).
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
    reporting; judged against the plant's (composite) truth."""
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    n = sample_length(plant.n)
    ident = identifier_of(robot, estimator_parameters(robot, {
        "method": 1, "solver": 2, "ident.noise_profile": 1, "noise.scale": 1.0}), DT)
    suite = SensorSuite(plant.n, scale=1.0, seed=seed, dt=DT)
    flagged = misfit = False
    for k in range(int(round(T_END / DT)) + 1):
        if k:
            plant.advance(DT)
        ident.update(k * DT, suite.update(suite.sample(plant.output_vector()[:n]), DT))
        rep = ident.core.report()
        flagged |= rep["identified"]["base"] or rep["identified"]["target"]
        misfit |= rep["misfit"]
    b = plant.base_now()
    truth = np.r_[b.mass, b.com, b.inertia, sc.target.mass, sc.target.com, sc.target.inertia]
    est, sd = np.asarray(ident.vector()), np.asarray(ident.std())
    out = {"worst": float(relative_errors(est, truth).max()),
           "within": int(np.sum(np.abs(est - truth) <= 2.0 * sd)),
           "flagged": flagged, "misfit": misfit, "fit": rep["model_fit"]}
    print(f"{sc.name}: {out}")
    return out


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


def test_weak_excitation_is_never_flagged_and_covered(runs):
    r = runs(0.1)
    assert not r["flagged"] and r["within"] >= 18


@pytest.mark.xfail(strict=True, reason="known limit: a false misfit on a rigid spacecraft at "
                   "0.1 rad (docs/identification.md, 'Weak excitation')")
def test_weak_excitation_no_false_misfit(runs):
    assert not runs(0.1)["misfit"]


def test_moderate_excitation_sd_cover_the_errors(runs):
    rs = [runs(0.2, seed) for seed in range(4)]
    assert sum(r["within"] for r in rs) >= 72, [r["within"] for r in rs]
    assert max(r["worst"] for r in rs) < 0.015 and not any(r["flagged"] for r in rs)


def test_held_out_servicer_slosh_misfit_found_and_covered():
    r = _run(*_held_out_slosh(), seed=0)
    assert r["misfit"] and not r["flagged"] and r["within"] >= 18
