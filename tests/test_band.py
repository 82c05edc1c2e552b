"""The rigid band (native/src/band.c, the estimator's ident.band; docs/identification.md, "The
rigid band"): the native band against its reference formulation (tests/oracles/band.py:
scipy's Butterworth, the reference filter's rows, one batch least squares) at one
linearisation point, and the estimator's answer against the composite rigid truth of flexible
spacecraft through the realistic sensors."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

from oracles.band import RowsFilter, band, low_pass
from oracles.information import noise_vector, sensor_noise, z_of_reported
from oracles.samples import fmu_identifier, guess_of, parameter_set_samples, sensed

_DP = ctypes.POINTER(ctypes.c_double)
#: SR_BAND_NSOS (native/src/band.h): the low-pass's second-order sections
NSOS = 3


class BandModel(ctypes.Structure):
    """sr_band_model (native/src/band.h)."""
    _fields_ = [("settle", ctypes.c_int), ("nm", ctypes.c_int), ("nl", ctypes.c_int),
                ("nc", ctypes.c_int), ("n1", ctypes.c_int), ("nq", ctypes.c_int),
                ("cols", ctypes.c_int), ("modes", ctypes.c_int), ("dt", ctypes.c_double),
                ("gain", ctypes.c_double), ("sos", (ctypes.c_double * 5) * NSOS)]


class VariantAnswer(ctypes.Structure):
    """sr_band_variant_answer (native/src/band.h)."""
    _fields_ = [("vec", ctypes.c_double * 20), ("bound", ctypes.c_double * 20),
                ("chi2", ctypes.c_double), ("dof", ctypes.c_double)]


def _p(a: np.ndarray):
    return a.ctypes.data_as(_DP)


@pytest.fixture(scope="module")
def lib():
    from spacerobot.core import load_library
    L = load_library()
    vp, d = ctypes.c_void_p, ctypes.c_double
    L.sr_info_model_init.argtypes = [vp, vp, _DP, _DP, d, d]
    L.sr_info_model_size.restype = ctypes.c_size_t
    L.sr_band_model_size.restype = ctypes.c_size_t
    L.sr_band_work_size.restype = ctypes.c_size_t
    L.sr_band_model_init.argtypes = [vp, vp, d]
    L.sr_band_model_init_modes.argtypes = [vp, vp, d]
    L.sr_band_data_init_modes.argtypes = [vp, vp, vp, ctypes.c_int, _DP, _DP]
    L.sr_band_data_size.argtypes = [vp, vp]
    L.sr_band_data_size.restype = ctypes.c_size_t
    L.sr_band_data_init.argtypes = [vp, vp, vp]
    L.sr_band_data_valid.argtypes = [vp, vp, vp]
    L.sr_band_add.argtypes = [vp, vp, vp, d, _DP, _DP, vp]
    L.sr_band_solve.argtypes = [vp, vp, vp, vp]
    L.sr_band_answer.argtypes = [vp, vp, _DP, _DP, _DP, _DP, _DP]
    L.sr_band_variant.argtypes = [vp, vp, ctypes.c_int, vp]
    assert L.sr_band_model_size() == ctypes.sizeof(BandModel)
    return L


class CBand:
    """The native band over a native information filter's model (ctypes); with ``modes``
    ((frequency [Hz], damping), ...) the found modes' band with those modes."""

    def __init__(self, L, robot, noise, z0, P0_mu, P0_theta, dt, modes=None):
        self.L = L
        self.im = ctypes.create_string_buffer(L.sr_info_model_size())
        assert L.sr_info_model_init(self.im, ctypes.byref(robot), _p(noise), _p(z0),
                                    float(P0_mu), float(P0_theta)) == 0
        self.bm = BandModel()
        init = L.sr_band_model_init_modes if modes else L.sr_band_model_init
        self.status = init(ctypes.byref(self.bm), self.im, float(dt))
        if self.status == 0:
            self.data = ctypes.create_string_buffer(L.sr_band_data_size(ctypes.byref(self.bm),
                                                                        self.im))
            self.work = ctypes.create_string_buffer(L.sr_band_work_size())
            L.sr_band_data_init(ctypes.byref(self.bm), self.im, self.data)
            if modes:
                assert self.init_modes(modes) == 0

    def init_modes(self, modes) -> int:
        f, zeta = (np.array(v, float) for v in zip(*modes)) if modes else (np.zeros(1),) * 2
        return self.L.sr_band_data_init_modes(ctypes.byref(self.bm), self.im, self.data,
                                              len(modes), _p(f), _p(zeta))

    def add(self, t, x, z) -> int:
        return self.L.sr_band_add(ctypes.byref(self.bm), self.im, self.data, float(t),
                                  _p(np.ascontiguousarray(x, float)),
                                  _p(np.ascontiguousarray(z, float)), self.work)

    def answer(self):
        self.L.sr_band_solve(ctypes.byref(self.bm), self.im, self.data, self.work)
        vec, bound, alt = np.zeros(20), np.zeros(20), np.zeros(20)
        chi2, dof = np.zeros(2), np.zeros(1)
        pick = self.L.sr_band_answer(ctypes.byref(self.bm), self.data, _p(vec), _p(bound),
                                     _p(alt), _p(chi2), _p(dof))
        return pick, vec, bound, alt, chi2, float(dof[0])

    def variant(self, which: int):
        """(estimates, bound, chi2, dof) of the last solve's variant which (1 the low-pass, 2
        all filters' columns, 3 the first filter's alone), None where it has none."""
        a = VariantAnswer()
        if self.L.sr_band_variant(ctypes.byref(self.bm), self.data, which, ctypes.byref(a)):
            return None
        return np.array(a.vec), np.array(a.bound), a.chi2, a.dof

    def valid(self) -> bool:
        return bool(self.L.sr_band_data_valid(ctypes.byref(self.bm), self.im, self.data))


def _models(lib, sc, dt, modes=None):
    """(native band, reference filter) of scenario sc's robot, the sensors' noise model at dt
    and the scenario's guesses and prior (the found modes' band with ``modes``)."""
    from spacerobot.core.robot_record import c_robot
    from spacerobot.sensors import default_parameters
    sd, sd_c, sd_b = sensor_noise(default_parameters(), dt)
    g, robot = sc.guess, c_robot(sc.robot, lib)
    z0 = guess_of(sc)
    cb = CBand(lib, robot, noise_vector(sd, sd_c, sd_b), z0, g.P0_mu, g.P0_theta, dt, modes)
    ref = RowsFilter(lib, robot, sc.robot.n_joints, False, sd, sd_c, g.P0_mu, g.P0_theta,
                     z_of_reported(z0), sd_gyro_bias=sd_b)
    ref.eiv = True
    return cb, ref


@pytest.mark.parametrize("dt", [0.01, 0.1, 0.2, 0.5, 2.0])
def test_low_pass_is_scipy_butter(lib, dt):
    """The band's low-pass is scipy.signal.butter's (order 6 at 0.15 Hz; the sections may
    differ, the cascade may not): the same impulse response to round-off, the same
    white-noise gain, its start 3 / 0.15 s."""
    from scipy.signal import sosfilt
    from spacerobot.robots import parameter_set_scenario
    cb, _ = _models(lib, parameter_set_scenario("spatial", "wings"), dt)
    assert cb.status == 0
    sos_ref, gain, settle = low_pass(dt)
    sos = np.array([[c[0], c[1], c[2], 1.0, c[3], c[4]] for c in cb.bm.sos])
    impulse = np.zeros(int(round(40.0 / 0.15 / dt)))
    impulse[0] = 1.0
    ours, ref = sosfilt(sos, impulse), sosfilt(sos_ref, impulse)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    assert cb.bm.gain == pytest.approx(gain, rel=1e-9)
    assert cb.bm.settle == settle == round(20.0 / dt)


@pytest.mark.parametrize("dt", [0.009, 2.5, float("nan")])
def test_sample_time_out_of_range_refused(lib, dt):
    from spacerobot.robots import parameter_set_scenario
    cb, _ = _models(lib, parameter_set_scenario("spatial", "wings"), 0.1)
    assert lib.sr_band_model_init(ctypes.byref(BandModel()), cb.im, float(dt)) == 1


#: the found modes' band's modes in its reference test: the panels' own (0.5 Hz, 0.005) and a
#: stand-in for a spurious second one (its lowest mode alone is then the model beside it)
MODES = ((0.5, 0.005), (1.3, 0.05))


def _short(lib, modes=None, t_end=150.0):
    """The spatial robot's wings (the issue's size) through the realistic sensors (seed 0),
    one sample every 0.2 s for t_end s: the native band and the reference's answers, both
    linearised at the truth (the found modes' band with ``modes``)."""
    from oracles.band import QS
    dt = 0.2
    sc, XT, truth = parameter_set_samples("spatial", "wings", t_end, dt)
    X = sensed(sc, XT, 0, dt)
    ts = dt * np.arange(len(X))
    cb, ref = _models(lib, sc, dt, modes)
    prior = (ref.Rinfo.copy(), ref.d.copy())
    zt = z_of_reported(truth)
    settle = low_pass(dt)[2]
    for k, (t, x) in enumerate(zip(ts, X)):
        assert cb.add(t, x, truth) == 0
        ref.eiv = k >= settle                 # the sums over the rows the band uses
        ref.add(t, x, zt)
    filters, blocks = (modes, "GCDT") if modes else (QS, "GC")
    return cb, cb.answer(), band(ref, prior, ts, X, dt, filters, blocks), truth


@pytest.fixture(scope="module")
def wings_short(lib):
    return _short(lib)


@pytest.fixture(scope="module")
def wings_short_modes(lib):
    return _short(lib, MODES, 100.0)      # (the reference's columns are the slow part)


@pytest.fixture(scope="module")
def wings_short_mode1(lib):
    """The found modes' band with one mode (its [R] of all filters' columns not kept)."""
    return _short(lib, MODES[:1], 60.0)


@pytest.mark.parametrize("run", ["wings_short", "wings_short_modes", "wings_short_mode1"])
def test_band_is_its_reference(run, request):
    """Both variants' chi2, the answer taken, its estimates, bound and degrees of freedom and
    the alternative's estimates as the reference's batch least squares computes them (the
    estimates to 1e-6 of the error scale: the prior's 1e-12 information makes the normal
    equations lose some digits); the compliance's band and the found modes' (MODES: all four
    blocks of columns per mode, the lowest mode alone beside them; with one mode, where all
    modes' answer is the lowest's alone); each variant through sr_band_variant."""
    from spacerobot.interface import error_scale
    cb, (pick, vec, bound, alt, chi2, dof), ref, truth = request.getfixturevalue(run)
    assert pick == {"lowpass": 1, "compliance": 2}[ref["pick"]]
    np.testing.assert_allclose(chi2, [ref["lowpass"][2], ref["compliance"][2]], rtol=1e-7)
    u, r_bound, _, r_dof, r_vec = ref[ref["pick"]]
    assert dof == r_dof
    scale = error_scale(truth)
    np.testing.assert_allclose(vec / scale, r_vec / scale, rtol=0, atol=1e-6)
    np.testing.assert_allclose(alt / scale, ref[ref["alt"]][4] / scale, rtol=0, atol=1e-6)
    if run == "wings_short_mode1":         # one model: no model-difference term
        assert pick == 2 and np.array_equal(vec, alt)
    else:       # the alternative differs (else the model-difference term would say nothing)
        assert np.max(np.abs(vec - alt) / scale) > 1e-4
    np.testing.assert_allclose(bound, r_bound, rtol=1e-6, atol=1e-12 * scale.max())
    # every variant's answer (est_band.c reports the found modes' from two of them)
    for which, name in enumerate(("lowpass", "compliance", "compliance1"), start=1):
        v_vec, v_bound, v_chi2, v_dof = cb.variant(which)
        _, r_bound, r_chi2, r_dof, r_vec = ref[name]
        assert v_chi2 == pytest.approx(r_chi2, rel=1e-7) and v_dof == r_dof, name
        np.testing.assert_allclose(v_vec / scale, r_vec / scale, rtol=0, atol=1e-6)
        np.testing.assert_allclose(v_bound, r_bound, rtol=1e-6, atol=1e-12 * scale.max())
    assert cb.variant(0) is None and cb.variant(4) is None
    assert cb.valid()


def test_band_refuses_bad_samples(wings_short):
    """A sample not after the last one, non-finite numbers, a linearisation with a mass <= 0:
    refused, the state unchanged."""
    cb, *_ = wings_short
    before = cb.data.raw
    x = np.zeros(64)
    z = np.r_[100.0, np.zeros(9), 10.0, np.zeros(9)]
    assert cb.add(0.0, x, z) == 1                                   # not after the last
    x_nan = np.full(64, np.nan)
    assert cb.add(1e6, x_nan, z) == 1
    z_bad = z.copy()
    z_bad[0] = -1.0
    assert cb.add(1e6, x, z_bad) == 1
    assert cb.data.raw == before


def test_modes_band_refuses_bad_modes(wings_short, wings_short_modes):
    """sr_band_data_init_modes: none, more than the model's two, not ascending, a frequency or
    damping out of range, or the compliance's model: refused (1), the state unchanged; a
    found modes' band with more modes in use than its filters is not valid."""
    cb, *_ = wings_short_modes
    before = cb.data.raw
    for modes in ((), ((0.3, 0.01),) * 3, ((0.5, 0.01), (0.3, 0.01)), ((0.0, 0.01),),
                  ((float("nan"), 0.01),), ((0.3, 0.0),), ((0.3, 1.5),)):
        assert cb.init_modes(modes) == 1, modes
    assert cb.data.raw == before and cb.valid()
    comp, *_ = wings_short
    comp_before = comp.data.raw
    assert comp.init_modes(((0.3, 0.01),)) == 1 and comp.data.raw == comp_before
    head = ctypes.cast(cb.data, ctypes.POINTER(ctypes.c_int))   # added, used, pick, nf
    assert head[3] == len(MODES)
    try:
        head[3] = 3                               # more modes than the model's filters
        assert not cb.valid()
    finally:
        ctypes.memmove(cb.data, before, len(before))
    assert cb.valid()


def _identify(robot, case, seed, values, dt=0.1, stop=300.0):
    from spacerobot.robots import parameter_set_scenario
    from dataclasses import replace
    if case == "rigid":
        sc = parameter_set_scenario(robot, "wings")
        sc = replace(sc, flex=replace(sc.flex, n=0))
        from oracles.samples import scenario_samples
        XT, truth = scenario_samples(sc, stop, dt)
    else:
        sc, XT, truth = parameter_set_samples(robot, case, stop, dt)
    X = sensed(sc, XT, seed, dt)
    ident = fmu_identifier(sc, dt, {"ident.noise_profile": 1, **values})
    for k, x in enumerate(X):
        ident.update_flat(dt * k, x)
    return ident._report(), truth


SERVICER = "tests/data/arm5.urdf"


@pytest.mark.slow
def test_band_on_flexible_spacecraft_through_the_sensors():
    """The issue's wings on the spatial robot and slosh on the held-out servicer (seeds 0, 1;
    300 s, the realistic sensors, the profile: the band automatic): the band reports, every
    estimate within 4 % of the composite truth (measured 0.52-3.0 %; the issue's goal is 3 %,
    which 2 of the 16 flexible runs of benchmarks/BAND.md miss, by 0.08 and 0.11 points), no
    flag, 90 % of the estimates within 2 sd (the issue's criterion; measured 80 of 80)."""
    from pathlib import Path
    from spacerobot.interface import relative_errors
    root = Path(__file__).resolve().parents[1]
    inside = total = 0
    for robot, case in (("spatial", "wings"), (str(root / SERVICER), "slosh")):
        for seed in (0, 1):
            r, truth = _identify(robot, case, seed, {})
            assert r["misfit_cause"] == "model" and r["band"] in (1, 2), (robot, case, seed)
            assert relative_errors(r["vector"], truth).max() < 0.04, (robot, case, seed)
            assert not r["identified"]["base"] and not r["identified"]["target"]
            inside += int(np.sum(np.abs(r["vector"] - truth) <= 2.0 * r["sd"]))
            total += 20
    assert inside >= 0.9 * total, f"{inside} of {total} within 2 sd"


@pytest.mark.slow
def test_servicer_wings_within_the_issue_goal():
    """The issue's wings on the held-out servicer through the sensors, the two seeds of
    benchmarks/BAND.md that missed the issue's 3 % before the band re-linearised its replay
    (4.61 % and 3.53 %, the filter's rigid point 465 % off): every estimate within 3 % of the
    composite truth (measured 2.93 % and 1.67 %), the compliance's answer reporting, no flag,
    at least 18 of 20 within 2 sd (measured 20 and 20)."""
    from pathlib import Path
    from spacerobot.interface import relative_errors
    robot = str(Path(__file__).resolve().parents[1] / SERVICER)
    for seed in (0, 3):
        r, truth = _identify(robot, "wings", seed, {})
        assert r["misfit_cause"] == "model" and r["band"] == 2, seed
        assert relative_errors(r["vector"], truth).max() < 0.03, \
            (seed, relative_errors(r["vector"], truth).max())
        assert not r["identified"]["base"] and not r["identified"]["target"]
        assert int(np.sum(np.abs(r["vector"] - truth) <= 2.0 * r["sd"])) >= 18, seed


@pytest.mark.slow
def test_band_leaves_a_rigid_spacecraft_alone():
    """Without flexible parts (the wings' scenario without its panels, the sensors) no misfit
    is found, the band does not report, and every output is the filter's with the band off."""
    on, truth = _identify("spatial", "rigid", 0, {})
    off, _ = _identify("spatial", "rigid", 0, {"ident.band": 2})
    assert on["band"] == 0 and not on["misfit"]
    for key in ("vector", "sd", "crb"):
        np.testing.assert_array_equal(on[key], off[key])


def test_band_options_refused():
    """ident.band = 1 needs the information filter and a sample time it takes: a clear error;
    automatic (0) is then off."""
    from spacerobot.robots import parameter_set_scenario
    sc = parameter_set_scenario("spatial", "wings")
    with pytest.raises(ValueError, match="ident.band = 1.*needs the information filter"):
        fmu_identifier(sc, 0.1, {"ident.band": 1})
    with pytest.raises(ValueError, match="ident.band = 1.*noise_dt from 0.01 to 2"):
        fmu_identifier(sc, 0.005, {"ident.band": 1, "ident.noise_profile": 1})
    assert fmu_identifier(sc, 0.005, {"ident.noise_profile": 1}) is not None


def test_corrupt_band_state_refused():
    """A restored Data block whose band counts are out of range (more rows used than samples
    added) is refused by the state check, with the band named, and by the core's update."""
    from spacerobot.robots import parameter_set_scenario
    sc = parameter_set_scenario("spatial", "wings")
    on = fmu_identifier(sc, 0.1, {"ident.noise_profile": 1})
    off = fmu_identifier(sc, 0.1, {"ident.noise_profile": 1, "ident.band": 2})
    state = on.core.get_state()
    assert on.core.check_state(state) == ""
    # the band's block is the Data block's last (the modal columns off), 8-byte aligned; its
    # head: int added, int used, ...: used > added is out of range
    at = (off.core.size + 7) // 8 * 8
    bad = bytearray(state)
    bad[at + 4:at + 8] = (5).to_bytes(4, "little", signed=True)
    assert "rigid band" in on.core.check_state(bytes(bad))
    from spacerobot.estimator.identifier import REJECT_NONFINITE
    _, XT, _ = parameter_set_samples("spatial", "wings", 0.2, 0.1)
    on.core.set_state(bytes(bad))
    assert on.update_flat(0.0, XT[0]) == REJECT_NONFINITE
    assert on.core.get_state() == bytes(bad)                # nothing written


def test_corrupt_found_modes_band_state_refused(lib):
    """With ident.modes = 1 the Data block's band part is the compliance band's block, the
    found modes' band's head (int nf, kept, full; doubles f, zeta), its band's block
    and the kept samples (4096 of t and the flat sample): that layout, and a head whose count
    of modes, of kept samples or full flag is out of range refused by the state check, the
    rigid band named."""
    from spacerobot.robots import parameter_set_scenario
    sc = parameter_set_scenario("spatial", "wings")
    values = {"ident.noise_profile": 1, "method": 1, "solver": 2, "ident.modes": 1}
    on = fmu_identifier(sc, 0.1, values)
    off = fmu_identifier(sc, 0.1, {**values, "ident.band": 2})
    up8 = lambda n: (n + 7) // 8 * 8                              # noqa: E731
    sizes = [lib.sr_band_data_size(ctypes.byref(cb.bm), cb.im)
             for cb in (_models(lib, sc, 0.1)[0], _models(lib, sc, 0.1, MODES)[0])]
    at = up8(off.core.size) + up8(sizes[0])
    slot = 1 + 24 + 3 * sc.robot.n_joints + 12                       # 1 + SR_X_LEN(n)
    assert on.core.size == at + 48 + up8(sizes[1]) + 8 * 4096 * slot
    state = on.core.get_state()
    assert on.core.check_state(state) == ""
    for field, value in ((0, 3), (0, -1), (1, 4097), (2, 2)):
        bad = bytearray(state)
        bad[at + 4 * field:at + 4 * field + 4] = value.to_bytes(4, "little", signed=True)
        assert "rigid band" in on.core.check_state(bytes(bad)), (field, value)


def test_band_state_with_a_bad_number_or_count_is_not_valid(wings_short):
    """sr_band_data_valid: the state after the run is valid; a NaN in its head (the previous
    sample's time), or more rows used than its samples give, is not."""
    cb, *_ = wings_short
    good = cb.data.raw
    assert cb.valid()
    head = ctypes.cast(cb.data, ctypes.POINTER(ctypes.c_int))
    added, used = head[0], head[1]
    t_prev = ctypes.cast(ctypes.addressof(cb.data) + 16, ctypes.POINTER(ctypes.c_double))
    try:
        t_prev[0] = float("nan")
        assert not cb.valid()
        ctypes.memmove(cb.data, good, len(good))
        head[1] = added                          # the first 3 / fc s give no rows
        assert used < added and not cb.valid()
    finally:
        ctypes.memmove(cb.data, good, len(good))
    assert cb.valid()


@pytest.mark.slow
def test_band_hands_back_where_its_own_rows_do_not_fit():
    """The issue's wings moved to 0.2 Hz (at the low-pass's edge; the spatial robot, seed 0,
    300 s): the band's chi2 is far beyond its noise's (measured 530 times), so it does not
    report (its answer was 71 % off with 13 of 20 within 2 sd) and every output is the held
    filter's, as with the band off."""
    from dataclasses import replace
    from oracles.samples import scenario_samples
    from spacerobot.robots import parameter_set_scenario
    sc = parameter_set_scenario("spatial", "wings")
    f0 = sc.flex.panels[0].f
    sc = replace(sc, flex=replace(sc.flex, panels=tuple(replace(p, f=p.f * 0.2 / f0)
                                                        for p in sc.flex.panels)))
    XT, _ = scenario_samples(sc, 300.0, 0.1)
    X = sensed(sc, XT, 0, 0.1)
    out = {}
    for setting in (0, 2):
        ident = fmu_identifier(sc, 0.1, {"ident.noise_profile": 1, "ident.band": setting})
        for k, x in enumerate(X):
            ident.update_flat(0.1 * k, x)
        out[setting] = ident._report()
    assert out[0]["misfit_cause"] == "model" and out[0]["band"] == 0
    for key in ("vector", "sd", "crb"):
        np.testing.assert_array_equal(out[0][key], out[2][key])
