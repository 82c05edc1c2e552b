"""The modal columns (ident.modes = 1, native/src/est_modal.c) against the truth of the
flexible plant (native/src/plant_leaves.c; docs/models.md 'Flexible appendages and slosh'):

* on the spatial robot's `wings`, `slosh` and `flexible` sets (the issue's sizes), 300 s of
  noise-free samples, momentum method, the modes found from the data: every estimate within
  1 % of the composite rigid truth (the plant's composite base, the target), and each true
  (cantilevered) frequency found within 1 %; the same samples with the modes off are several
  times further off (what the columns remove is real);
* on the rigid spacecraft (`default`) nothing is found and the estimates stay exact;
* the rules: the modal columns need the momentum method, the joint solver and no momentum
  window; a given frequency below 0.05 Hz is refused; the state round trip carries the modes.
"""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot.core.plant import NativePlant
from spacerobot.core.sample import sample_length
from spacerobot.estimator.identifier import Identifier
from spacerobot.interface import relative_errors
from spacerobot.robots import parameter_set_scenario

T_END = 300.0
DT = 0.1
#: the cantilevered frequencies of the sets' parts [Hz] (robots.SPATIAL_PANELS, SPATIAL_SLOSH)
TRUE_F = {"wings": (0.5,), "slosh": (0.30, 0.35), "flexible": (0.5, 0.30, 0.35)}


def _record(name: str, t_end: float = T_END):
    """The noise-free samples of the spatial robot's parameter set ``name`` (the plant with its
    excitation on), and the composite truth (20,) the rigid model should converge to."""
    sc = parameter_set_scenario("spatial", name)
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    n = sample_length(plant.n)
    xs = [plant.output_vector()[:n].copy()]
    for _ in range(int(round(t_end / DT))):
        plant.advance(DT)
        xs.append(plant.output_vector()[:n].copy())
    base = plant.base_now()                   # the composite: panels at rest, slosh at rest
    truth = np.r_[base.mass, base.com, base.inertia,
                  sc.target.mass, sc.target.com, sc.target.inertia]
    return sc, np.array(xs), truth


def _identify(sc, xs, modes: int, **extra):
    ident = Identifier(sc.robot, sc.guess, "momentum", solver="joint",
                       excite={"ident.modes": modes, **extra})
    for k, x in enumerate(xs):
        ident.update_flat(k * DT, x)
    return ident


@pytest.fixture(scope="module")
def runs():
    """name -> (worst relative error with the modes, without, the modes found [Hz])"""
    cache = {}

    def get(name):
        if name not in cache:
            sc, xs, truth = _record(name)
            on = _identify(sc, xs, 1)
            off = _identify(sc, xs, 2)
            rep = on.core.report()
            found = rep["mode_f"][rep["mode_f"] > 0]
            cache[name] = (float(relative_errors(on.vector(), truth).max()),
                           float(relative_errors(off.vector(), truth).max()), found)
        return cache[name]
    return get


def _check(runs, name):
    on, off, found = runs(name)
    print(f"{name}: worst {100 * on:.3f} % with the modes ({np.round(found, 4)} Hz), "
          f"{100 * off:.2f} % without")
    assert on < 0.01
    assert off > 5.0 * on
    for f in TRUE_F[name]:
        assert np.min(np.abs(found - f)) < 0.01 * f, (f, found)


@pytest.mark.slow
def test_wings_within_one_percent_with_the_modes_found(runs):
    _check(runs, "wings")


def test_slosh_within_one_percent_with_the_modes_found(runs):
    _check(runs, "slosh")


@pytest.mark.slow
def test_wings_and_slosh_within_one_percent_with_the_modes_found(runs):
    _check(runs, "flexible")


def test_rigid_spacecraft_finds_no_mode_and_stays_exact():
    """The rigid robot (80 s, past the first search): no mode, the estimates as exact as the
    rigid solver's (within twice its error, which is below 1e-4 of the truth at 80 s: the
    prior's pull)."""
    sc, xs, truth = _record("default", 80.0)
    on = _identify(sc, xs, 1)
    off = _identify(sc, xs, 2)
    assert np.all(on.core.report()["mode_f"] == 0.0)
    e_on = relative_errors(on.vector(), truth).max()
    e_off = relative_errors(off.vector(), truth).max()
    print(f"rigid: worst {e_on:.2e} with ident.modes = 1, {e_off:.2e} without")
    assert e_off < 1e-4 and e_on <= 2.0 * e_off + 1e-12


@pytest.mark.parametrize("change, message", [
    ({"solver": 1}, "needs the momentum method (method = 1), the joint solver (solver = 2)"),
    ({"method": 2}, "needs the momentum method"),
    ({"ident.momentum_window": 2.0}, "no momentum window"),
    ({"ident.mode_f[2]": 0.01}, "ident.mode_f[2] must be 0 (not given) or a frequency from"),
    ({"ident.mode_f[1]": 3.5}, "ident.mode_f[1] must be a frequency from 0 to 3 Hz"),
])
def test_bad_settings_are_refused_with_their_names(change, message):
    sc = parameter_set_scenario("spatial", "wings")
    opts = {"method": 1, "solver": 2, "ident.modes": 1, **change}
    method = "force" if opts.pop("method") == 2 else "momentum"
    solver = "paper" if opts.pop("solver") == 1 else "joint"
    window = opts.pop("ident.momentum_window", 0.0)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        Identifier(sc.robot, sc.guess, method, solver=solver, window=window, excite=opts)


def test_state_round_trip_carries_the_modes():
    """A copy of the state after the first search (70 s of the `wings` set) continues as the
    original does: the same modes and estimates after 20 s more."""
    sc, xs, _ = _record("wings", 90.0)
    a = _identify(sc, xs[:701], 1)
    b = Identifier(sc.robot, sc.guess, "momentum", solver="joint", excite={"ident.modes": 1})
    b.set_state(a.get_state())
    assert np.any(a.core.report()["mode_f"] > 0.0)
    for k in range(701, len(xs)):
        a.update_flat(k * DT, xs[k])
        b.update_flat(k * DT, xs[k])
    np.testing.assert_array_equal(a.vector(), b.vector())
    np.testing.assert_array_equal(a.core.report()["mode_f"], b.core.report()["mode_f"])
