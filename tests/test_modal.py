"""The modal columns (ident.modes = 1, native/src/est_modal.c) against the truth of the
flexible plant (native/src/plant_leaves.c; docs/models.md 'Flexible appendages and slosh'):

* on the spatial robot's `wings`, `slosh` and `flexible` sets (the issue's sizes), 300 s of
  noise-free samples, momentum method, the modes found from the data: every estimate within
  1 % of the composite rigid truth (the plant's composite base, the target), and each true
  (cantilevered) frequency found within 1 %; the same samples with the modes off are several
  times further off (what the columns remove is real);
* on a spacecraft the columns were not developed on (tests/data/arm5.urdf: a 900 kg hub
  with a 5-joint arm) carrying the same wings and slosh (`flexible`): the same, every estimate
  within 1 % (measured 0.50 %; 44 % without the columns);
* on the rigid spacecraft (`default`) nothing is found and the estimates stay exact;
* over the momentum window (ident.momentum_window > 0: each sample's columns differenced
  against the window's reference, as its rigid rows are): after the first search and its
  replay, the estimates are those of a batch least squares written here (the test oracle's
  rigid rows, the modal columns from the filter's exact discretisation, the same prior) on the
  `wings` set; on the rigid spacecraft nothing is found and the estimates are the rigid
  window's;
* through the sensors (their realistic defaults, seed 0, the noise profile: its 5 s window,
  the thrust's consider term), the joint solver with the columns on the `wings` and `slosh`
  sets: at least 18 of the 20 estimates within 2 reported sd of the composite truth, and the
  wings' worst error below 10 %; beside the profile's filter and band, the columns report
  where the band hands back (wings at 0.2 Hz: below 5 %, against the held filter's 90 %);
* the rules: the modal columns need the momentum method and the joint solver; a given
  frequency below 0.05 Hz is refused; the state round trip carries the modes (with the window
  too: its ring of the filters' states); a state whose ring names another sample is refused.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import ARM5_URDF
from oracles.modal import drive, filter_states, modal_columns
from oracles.samples import fmu_identifier, parameter_set_samples
from spacerobot.estimator.identifier import Identifier
from spacerobot.interface import relative_errors
from spacerobot.robots import parameter_set_scenario

T_END = 300.0
DT = 0.1
#: the cantilevered frequencies of the sets' parts [Hz] (robots.SPATIAL_PANELS, SPATIAL_SLOSH)
TRUE_F = {"wings": (0.5,), "slosh": (0.30, 0.35), "flexible": (0.5, 0.30, 0.35)}


def _record(name: str, t_end: float = T_END, robot: str = "spatial", amplitude=None):
    """``robot``'s parameter set ``name``: scenario, noise-free samples every DT, composite
    truth (oracles.samples.parameter_set_samples)."""
    return parameter_set_samples(robot, name, t_end, DT, amplitude)


def _identify(sc, xs, modes: int, window: float = 0.0, point: bool = False, **extra):
    ident = Identifier(sc.robot, sc.guess, "momentum", solver="joint", window=window,
                       moving_point=point, excite={"ident.modes": modes, **extra})
    for k, x in enumerate(xs):
        ident.update_flat(k * DT, x)
    return ident


@pytest.fixture(scope="module")
def runs():
    """(name, robot) -> (worst relative error with the modes, without, the modes found
    [Hz])"""
    cache = {}

    def get(name, robot="spatial"):
        if (name, robot) not in cache:
            sc, xs, truth = _record(name, robot=robot)
            on = _identify(sc, xs, 1)
            off = _identify(sc, xs, 2)
            rep = on.core.report()
            found = rep["mode_f"][rep["mode_f"] > 0]
            cache[name, robot] = (float(relative_errors(on.vector(), truth).max()),
                                  float(relative_errors(off.vector(), truth).max()), found)
        return cache[name, robot]
    return get


def _check(runs, name, robot="spatial"):
    on, off, found = runs(name, robot)
    print(f"{name} on {Path(robot).name}: worst {100 * on:.3f} % with the modes "
          f"({np.round(found, 4)} Hz), {100 * off:.2f} % without")
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


@pytest.mark.slow
def test_held_out_spacecraft_within_one_percent_with_the_modes_found(runs):
    _check(runs, "flexible", ARM5_URDF)


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
    ({"solver": 1}, "needs the momentum method (method = 1) and the joint solver (solver = 2)"),
    ({"method": 2}, "needs the momentum method"),
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


@pytest.mark.parametrize("window", [0.0, 5.0])
def test_state_round_trip_carries_the_modes(window):
    """A copy of the state after the first search (70 s of the `wings` set) continues as the
    original does: the same modes and estimates after 20 s more (with the momentum window:
    its ring of the filters' states carried too)."""
    sc, xs, _ = _record("wings", 90.0)
    a = _identify(sc, xs[:701], 1, window=window, point=window > 0.0)
    b = Identifier(sc.robot, sc.guess, "momentum", solver="joint", window=window,
                   moving_point=window > 0.0, excite={"ident.modes": 1})
    b.set_state(a.get_state())
    assert np.any(a.core.report()["mode_f"] > 0.0)
    for k in range(701, len(xs)):
        a.update_flat(k * DT, xs[k])
        b.update_flat(k * DT, xs[k])
    np.testing.assert_array_equal(a.vector(), b.vector())
    np.testing.assert_array_equal(a.core.report()["mode_f"], b.core.report()["mode_f"])


# -- over the momentum window: a batch least squares written here ------------------------------

WINDOW = 5.0


def _batch_estimates(sc, xs, modes, point: bool):
    """The rigid estimates (20,) of the batch least squares over every sample's rows
    [modal columns | rigid rows] over the momentum window WINDOW (> 0; the oracle's rows,
    weights and prior; the modal unknowns' prior information 1e-12, as the estimator's)."""
    from oracles.estimator.identifier import Identifier as Oracle
    o = Oracle(sc.robot, sc.guess, "momentum", "joint", window=WINDOW, moving_point=point)
    meas = [o._unflatten(np.asarray(x, float)) for x in xs]
    t = DT * np.arange(len(xs))
    u = np.array([drive(m["A"], m["a_S"], m["alpha_B"], m["omega_B"]) for m in meas])
    states = [filter_states(u, t, 2.0 * np.pi * f, z) for f, z in modes]
    act = o.layout.standard_active
    rows, rhs = [], []
    for k in range(len(xs)):
        r = o.rows(t[k], meas[k])
        if r is None:
            continue
        A, b, phi, y, psi = o._identified_rows(*r)
        Y, yy = o.solver._stack(A, b, phi, y, psi)
        limit = t[k] - WINDOW + 1e-9 * max(1.0, t[k])
        ref = max([j for j in range(k) if t[j] <= limit], default=0)
        p = meas[k]["r_S"] if point else np.zeros(3)
        wt = np.r_[np.full(len(b), o._w_lin), np.full(len(y), o._w_ang)]
        blocks = []
        for st in states:
            c = (modal_columns(st[k, 0], st[k, 1], meas[k], p)
                 - modal_columns(st[ref, 0], st[ref, 1], meas[ref], p))
            blocks.append(c[np.r_[o.layout.rows_lin, 3 + o.layout.rows_ang]] * wt[:, None])
        rows.append(np.hstack(blocks + [Y[:, act]]))
        rhs.append(yy)
    nm = 165 * len(modes)
    info = 1.0 / o.solver.prior()[act]
    pi0 = o.solver.pi[act]
    P = np.vstack([np.hstack([1e-6 * np.eye(nm), np.zeros((nm, len(act)))]),
                   np.hstack([np.zeros((len(act), nm)), np.diag(np.sqrt(info))])])
    X = np.vstack(rows + [P])
    Y = np.concatenate(rhs + [np.r_[np.zeros(nm), np.sqrt(info) * pi0]])
    z = np.linalg.lstsq(X, Y, rcond=None)[0][nm:]
    full = o.solver.pi.copy()
    full[act] = z
    return o.solver.vector_of(full)


def test_windowed_columns_are_the_batch_least_squares(point=True):
    """The `wings` set, 70 s (the first search at 60 s found the modes and every kept sample
    was solved again with its window's reference) over a 5 s momentum window, the angular rows
    about the moving point (the sensors' profile's; about the origin the columns take the
    first-sample form's shift, which the accuracy tests above cover): the estimates within
    1e-9 (relative, error scale) of the batch least squares written here with the modes the
    estimator reports (the Givens solve and LAPACK's differ by round-off only)."""
    sc, xs, truth = _record("wings", 70.0)
    ident = _identify(sc, xs, 1, window=WINDOW, point=point)
    rep = ident.core.report()
    modes = [(f, z) for f, z in zip(rep["mode_f"], rep["mode_zeta"]) if f > 0.0]
    assert modes and min(abs(f - 0.5) for f, _ in modes) < 0.01
    batch = _batch_estimates(sc, xs, modes, point)
    gap = relative_errors(np.asarray(ident.vector()), batch).max()
    err = relative_errors(np.asarray(ident.vector()), truth).max()
    print(f"window {WINDOW} s, point {point}: modes {modes}; gap to the batch {gap:.1e}, "
          f"worst error {100 * err:.3f} %")
    assert gap < 1e-9


def test_windowed_rigid_spacecraft_finds_no_mode_and_matches_the_rigid_window():
    """The rigid robot (80 s, past the first search) over a 5 s momentum window about the
    moving point: no mode; the estimates within 1e-9 (relative) of the rigid window's."""
    sc, xs, truth = _record("default", 80.0)
    on = _identify(sc, xs, 1, window=WINDOW, point=True)
    off = _identify(sc, xs, 2, window=WINDOW, point=True)
    assert np.all(on.core.report()["mode_f"] == 0.0)
    gap = relative_errors(np.asarray(on.vector()), np.asarray(off.vector())).max()
    print(f"rigid, window: {gap:.1e} between ident.modes = 1 and 2; "
          f"{relative_errors(off.vector(), truth).max():.1e} from the truth")
    assert gap < 1e-9


@pytest.mark.parametrize("name, amplitude", [
    ("wings", None), ("slosh", None),
    pytest.param("wings", 0.3, marks=[pytest.mark.slow, pytest.mark.xfail(
        strict=True, reason="known limit: at 0.3 rad the wings bend by up to 33 degrees, "
        "beyond the columns' first order, and the sd do not cover (docs/identification.md "
        "section 8, 'Limits')")]),
])
def test_sensors_windowed_columns_sd_cover_the_error(name, amplitude):
    """Through the sensors (realistic defaults, seed 0) with the noise profile (its 5 s
    momentum window about the base, the thrust's consider term, the rows' correlation) and
    the joint solver with the columns, 300 s: at least 18 of the 20 estimates within 2
    reported sd of the composite truth (measured 20 and 20); the wings' worst error below 10 %
    (measured 2.26 %, the rows compensated for the sensors' noise, est_modal.h; 5.5 % before
    that, 46 % without the columns). A known limit, a strict expected failure: the wings with
    the excitation at 0.3 rad (three times the set's) are 8.88 % off with 4 of 20 within 2 sd,
    and nothing says so."""
    from spacerobot.sensors import SensorSuite
    sc, xs, truth = _record(name, amplitude=amplitude)
    ident = fmu_identifier(sc, DT, {"method": 1, "solver": 2, "ident.modes": 1,
                                    "ident.information": 2, "ident.noise_profile": 1,
                                    "noise.scale": 1.0})
    suite = SensorSuite(sc.robot.n_joints, scale=1.0, seed=0, dt=DT)
    for k, x in enumerate(xs):
        ident.update(k * DT, suite.update(suite.sample(x), DT))
    _, worst, within = _scored(ident, truth)
    print(f"{name}, sensors: worst {100 * worst:.2f} %, {within} of 20 within 2 sd")
    assert within >= 18
    if name == "wings":
        assert worst < 0.10


def _scored(ident, truth):
    """(the least-squares estimates, their worst error against truth relative to the error
    scale, the estimates within 2 reported sd of truth)."""
    est, sd = np.asarray(ident.vector()), np.asarray(ident.std())
    return est, relative_errors(est, truth).max(), int(np.sum(np.abs(est - truth) <= 2.0 * sd))


def _slow_wings(f_hz: float, robot: str = "spatial"):
    """``robot``'s `wings` set with the panels' cantilevered frequency moved to f_hz:
    scenario, noise-free samples every DT, composite truth."""
    from dataclasses import replace
    from oracles.samples import scenario_samples
    sc = parameter_set_scenario(robot, "wings")
    panels = tuple(replace(p, f=f_hz) for p in sc.flex.panels)
    sc = replace(sc, flex=replace(sc.flex, panels=panels))
    return (sc, *scenario_samples(sc, T_END, DT))


def _sensed_run(sc, xs, seed: int, modes: int, **extra):
    """The library as the FMU builds it with the profile and the joint solver (ident.modes =
    modes, the rigid band automatic unless ``extra`` says), fed the samples xs through the
    sensors (realistic defaults, seed): (identifier, its last report, whether a body was ever
    flagged)."""
    from spacerobot.sensors import SensorSuite
    ident = fmu_identifier(sc, DT, {"method": 1, "solver": 2, "ident.modes": modes,
                                    "ident.noise_profile": 1, "noise.scale": 1.0, **extra})
    suite = SensorSuite(sc.robot.n_joints, scale=1.0, seed=seed, dt=DT)
    flagged = False
    for k, x in enumerate(xs):
        ident.update(k * DT, suite.update(suite.sample(x), DT))
        rep = ident.core.report()
        flagged |= rep["identified"]["base"] or rep["identified"]["target"]
    return ident, rep, flagged


def test_columns_report_where_the_band_hands_back():
    """The library with the modal columns beside the profile (ident.modes = 1, the joint
    solver; the rigid band automatic, on by the profile), through the sensors (seed 0), 300 s.
    The `wings` set at 0.2 Hz: the band's own rows do not fit (diag.band 0: the low-pass at
    0.15 Hz damps the mode too little), the filter finds the rigid model's misfit, the columns
    a mode near 0.2 Hz, so the joint solver with the columns reports: worst error below 5 %
    (measured 2.22 %; seeds 0-7 1.95-8.5 %, benchmarks/LOW_MODES.md), >= 18 of 20 within
    2 sd (measured 20); without the columns the held filter's answer stays, far off (measured
    89.7 % on the least-squares estimates scored here, ident.vector(); the FMU's outputs,
    after the physical projection, 270 %) but covered (>= 16 of 20 within 2 sd, measured 18);
    misfit, no flag in either.
    The `slosh` set's misfit is the thrust scale's, not coloured: the filter still reports,
    its estimates those of the run without the columns to within 0.2 % of the error scale
    (measured 0.08 %: the filter is linearised at the least-squares answer, which with the
    columns is compensated for the rows' errors in variables, est_modal.h)."""
    for name in ("wings", "slosh"):
        sc, xs, truth = _slow_wings(0.2) if name == "wings" else _record(name)
        est = {}
        for modes in (1, 2):
            ident, rep, flagged = _sensed_run(sc, xs, 0, modes)
            est[modes], worst, within = _scored(ident, truth)
            assert rep["misfit"] and not flagged, (name, modes)
            if name == "wings":
                print(f"wings at 0.2 Hz, modes {modes}: worst {100 * worst:.2f} %, "
                      f"{within} of 20 within 2 sd, mode_f {rep['mode_f']}")
                assert rep["misfit_cause"] == "model" and rep["band"] == 0
                if modes == 1:
                    assert np.any(np.abs(rep["mode_f"] - 0.2) < 0.005), rep["mode_f"]
                    assert worst < 0.05 and within >= 18
                else:
                    assert worst > 0.3 and within >= 16
        if name == "slosh":
            assert rep["misfit_cause"] == "thrust"
            assert relative_errors(est[1], est[2]).max() < 2e-3


def test_columns_compensate_the_rows_noise():
    """Errors in variables (est_modal.h): through the sensors the window rows' position and
    velocities are noisy, and the regressors' noise shrinks every mass and inertia (the wings'
    set at 0.3 Hz, seed 1, without the compensation: all eight masses and principal inertias
    1.35-3.88 % low, mean -2.62 %). With the rows' expected noise Gram matrix taken out of the
    modal solve, their mean signed error against the composite truth is within 1.5 % (measured
    -0.56 %), the worst of the 20 below 5 % (measured 3.71 %) and >= 18 of 20 within 2 sd
    (measured 20). Same set-up as test_columns_report_where_the_band_hands_back, the rigid
    band off (with it the found modes' band reports there: test_found_modes_band_reports)."""
    sc, xs, truth = _slow_wings(0.3)
    ident, rep, _ = _sensed_run(sc, xs, 1, 1, **{"ident.band": 2})
    assert np.any(np.abs(rep["mode_f"] - 0.3) < 0.005), rep["mode_f"]
    est, worst, within = _scored(ident, truth)
    diag = [0, 4, 5, 6, 10, 14, 15, 16]                    # m, Ixx, Iyy, Izz of each body
    signed = (est[diag] - truth[diag]) / truth[diag]
    print(f"wings at 0.3 Hz, seed 1: mean signed {100 * signed.mean():.2f} %, "
          f"worst {100 * worst:.2f} %, {within} within 2 sd")
    assert abs(signed.mean()) < 0.015, signed
    assert worst < 0.05 and within >= 18


def test_found_modes_band_reports():
    """The found modes' band (est_band.h: the rigid band's rows with the columns of the modes
    the search found, where the compliance band hands back): the `wings` set at 0.3 Hz through
    the sensors (seed 1), the library as the FMU builds it with the profile and the columns
    (the band automatic), 300 s: diag.band 3, every estimate within 3 % of the composite
    truth (the issue's goal; measured 1.07 %, against the joint solver's 3.71 % with the band
    off: test_columns_compensate_the_rows_noise), >= 18 of 20 within 2 sd (measured 20), the
    misfit found, no flag."""
    sc, xs, truth = _slow_wings(0.3)
    ident, rep, flagged = _sensed_run(sc, xs, 1, 1)
    _, worst, within = _scored(ident, truth)
    print(f"wings at 0.3 Hz, seed 1, found modes' band: worst {100 * worst:.2f} %, "
          f"{within} within 2 sd, mode_f {rep['mode_f']}")
    assert rep["misfit_cause"] == "model" and rep["band"] == 3 and not flagged
    assert worst < 0.03 and within >= 18


@pytest.mark.slow
def test_found_modes_band_takes_the_fewest_modes_that_fit():
    """The held-out servicer's wings moved to 0.3 Hz through the sensors, seed 7, where the
    search also finds a second mode (at 2.57 Hz): the found modes' band reports (diag.band 3)
    with the lowest mode's columns alone, which fit: every estimate within 1.5 % of the
    composite truth (measured 0.753 % on the FMU's outputs, benchmarks/LOW_MODES_SEEDS_4_7.md;
    with both modes' columns the batch study's answer is 3.12 % off with 10 of 20 within 2 sd,
    LOW_BAND_SEEDS_4_7.md), >= 18 of 20 within 2 sd (the model-difference term, both modes'
    answer beside it; measured 20), no flag."""
    sc, xs, truth = _slow_wings(0.3, ARM5_URDF)
    ident, rep, flagged = _sensed_run(sc, xs, 7, 1)
    _, worst, within = _scored(ident, truth)
    print(f"servicer's wings at 0.3 Hz, seed 7: worst {100 * worst:.3f} %, {within} within "
          f"2 sd, mode_f {rep['mode_f']}")
    assert rep["band"] == 3 and not flagged
    assert np.sum(rep["mode_f"] > 0) >= 2 and np.any(np.abs(rep["mode_f"] - 0.3) < 0.005)
    assert worst < 0.015 and within >= 18


def test_corrupt_window_ring_is_refused():
    """A state whose window ring names another sample than the one it holds (the newest entry's
    index changed) is refused with the modal columns' message; the identifier keeps its own."""
    import struct
    sc, xs, _ = _record("wings", 10.0)
    a = _identify(sc, xs, 1, window=WINDOW, point=True)
    st = bytearray(a.get_state())
    newest = struct.pack("<dd", float(len(xs) - 1), (len(xs) - 1) * DT)   # [index, t, ...]
    at = st.rfind(newest)                        # (the ring is the block's last part)
    assert at > len(st) // 2
    st[at:at + 8] = struct.pack("<d", float(len(xs) - 2))
    before = a.vector()
    with pytest.raises(ValueError, match="modal columns"):
        a.set_state(bytes(st))
    np.testing.assert_array_equal(a.vector(), before)
