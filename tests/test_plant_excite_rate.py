"""The plant's excitation rate (issue #29 point 3): ``Plant.set_excitation_rate`` /
``ident.excite_rate``.

A rate change dips the excitation level to 0 along the quintic ramp, switches the channel
table (period / rate, joint amplitudes re-bounded) where the level and both its derivatives
are 0, then ramps back to the requested level. Checked here against independent NumPy
computations of the references:

* ``s(t)``: the quintic ``p(x) = 10 x^3 - 15 x^4 + 6 x^5`` written out here, ``x = (t - t0) /
  ramp``; the channels: ``spacerobot.robots.Excitation(period=period / rate).channels``
  evaluated in NumPy as ``f = a/2 (sin(w1 t + p1) + sin(w2 t + p2))``;
* ``att_ref = s f`` and ``qd_ref = s' f + s f'`` (product rule) at every communication point,
  ramps included;
* the bounds ``|att_ref| <= att_max``, ``|qd_ref| <= qd_max`` and ``|qdd_ref| <= qdd_max``
  (finite difference of ``qd_ref``: by the mean value theorem each quotient is ``qdd_ref`` at
  some instant, so the bound holds up to rounding, tolerance 1e-9 rad/s2);
* refusals, cancellation, state round trip and the FMU inputs/outputs (both flavours).

Scenario: the spatial robot (3 attitude axes, 6 joints), ``excite.ramp = 2 s``,
``excite.period = 8 s`` (so a run of a few seconds covers ramps and the switch), dt = 0.05 s.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from spacerobot.plant import Plant
from spacerobot.robots import Excitation, scenario

RAMP, PERIOD, DT = 2.0, 8.0, 0.05
TOL_REF = 1e-9           # references vs the NumPy evaluation [rad, rad/s]
TOL_FD = 1e-9            # finite-difference qdd_ref above qdd_max (rounding only) [rad/s2]


# ------------------------------------------------------------------------------------------------
# independent computations
# ------------------------------------------------------------------------------------------------

def quintic(t: float, t0: float, s0: float, s1: float, T: float = RAMP):
    """(s, s', s'') of the ramp from s0 (at t0) to s1 (at t0 + T), written out here."""
    x = min(max((t - t0) / T, 0.0), 1.0)
    p = x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x)
    dp = 30.0 * x * x * (1.0 - x) ** 2 / T
    ddp = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (T * T)
    d = s1 - s0
    return s0 + d * p, d * dp, d * ddp


def channels(ex: Excitation, rate: float, n_att: int, n: int) -> np.ndarray:
    """The channel table at ``rate`` (Excitation with period / rate)."""
    return dataclasses.replace(ex, period=ex.period / rate).channels(n_att, n)


def f_and_derivs(tab: np.ndarray, t: float):
    """(f, f', f'') of every channel at t (NumPy)."""
    a, w1, p1, w2, p2 = tab.T
    f = 0.5 * a * (np.sin(w1 * t + p1) + np.sin(w2 * t + p2))
    fd = 0.5 * a * (w1 * np.cos(w1 * t + p1) + w2 * np.cos(w2 * t + p2))
    fdd = -0.5 * a * (w1 * w1 * np.sin(w1 * t + p1) + w2 * w2 * np.sin(w2 * t + p2))
    return f, fd, fdd


def expected_refs(tab, t, s, sd, n_att):
    """(att_ref, qd_ref) = (s f over the attitude rows, s' f + s f' over the joint rows)."""
    f, fd, _ = f_and_derivs(tab, t)
    return s * f[:n_att], sd * f[n_att:] + s * fd[n_att:]


# ------------------------------------------------------------------------------------------------
# plant and runs
# ------------------------------------------------------------------------------------------------

def make_plant(**ex_changes):
    sc = scenario("spatial")
    ex = dataclasses.replace(sc.excitation, ramp=RAMP, period=PERIOD, **ex_changes)
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h, ex)
    return p, ex, 3, sc.robot.n_joints


def run(p, n_steps, requests=None):
    """Advance n_steps of DT; ``requests[k]`` (a rate) is asked for before step k. Returns one
    record per communication point after each step (t, level triple, rate pair, outputs)."""
    requests = requests or {}
    rows = []
    for k in range(n_steps):
        if k in requests:
            p.set_excitation_rate(requests[k])
        p.advance(DT)
        o = p.outputs()
        rows.append({"t": p.t, "lev": p.excitation_level(), "rate": p.excitation_rate(),
                     "level_out": float(o["excite_level"][0]),
                     "rate_out": float(o["excite_rate"][0]),
                     "att": o["att_ref"].copy(), "qd": o["qd_ref"].copy()})
    return rows


# ------------------------------------------------------------------------------------------------
# 1. before any rate request: the plant's own table
# ------------------------------------------------------------------------------------------------

def test_references_before_any_rate_request_are_the_own_channels():
    """Excitation switched on at t = 0 (level 0 -> 1 over 2 s), run 4 s: at every point
    att_ref = s f and qd_ref = s' f + s f' with the channels of Excitation(period) and the
    quintic s(t) from t0 = 0, to 1e-9 (measured 1.4e-16); excitation_level() = (s, s', s'')
    equals the quintic to 1e-10 (measured 8e-16); the excite_rate output and
    excitation_rate() are 1."""
    p, ex, na, n = make_plant()
    assert p.excitation_rate() == (1.0, 1.0)
    assert p.outputs()["excite_rate"][0] == 1.0
    p.set_excitation(1.0)
    tab = channels(ex, 1.0, na, n)
    rows = run(p, 80)
    err_ref = err_lev = 0.0
    for r in rows:
        s, sd, sdd = quintic(r["t"], 0.0, 0.0, 1.0)
        err_lev = max(err_lev, float(np.max(np.abs(np.subtract(r["lev"], (s, sd, sdd))))))
        att, qd = expected_refs(tab, r["t"], s, sd, na)
        err_ref = max(err_ref, float(np.max(np.abs(r["att"] - att))),
                      float(np.max(np.abs(r["qd"] - qd))))
        assert r["rate_out"] == 1.0 and r["rate"] == (1.0, 1.0)
    print(f"own table: refs vs NumPy {err_ref:.1e}, level vs quintic {err_lev:.1e}")
    assert err_lev < 1e-10
    assert err_ref < TOL_REF
    # not vacuous: the run covers the ramp and the settled level, with sizeable references
    assert rows[-1]["lev"] == (1.0, 0.0, 0.0) and 0.0 < rows[10]["lev"][0] < 1.0
    assert max(np.abs(r["att"]).max() for r in rows) > 0.1 * ex.att_max


# ------------------------------------------------------------------------------------------------
# 2. a rate change at level 1
# ------------------------------------------------------------------------------------------------

def test_rate_change_dips_switches_at_zero_and_follows_the_new_table():
    """Level settled at 1, rate 4 asked for at t = 3 s; run to t = 12 s.

    * the level dips to 0 (1 -> 0 along the quintic from t = 3 s) and is back at 1 within
      2 x ramp + one step of the request (measured: 0 at t = 5.00, back to 1 at 7.00);
    * the excite_rate output changes once, 1 -> 4, between a point where the level and both
      its derivatives are exactly 0 and the next;
    * att_ref = s f and qd_ref = s' f + s f' at every point, ramps included, with the old table
      before the switch and the table of Excitation(period = period / 4) after it; s(t) from
      the quintic written out here (down from t = 3 s, up from the switch), at the plant's
      time: to 1e-9 (measured 6e-14 before the switch, 2e-16 after); excitation_level()
      against that quintic to 1e-10 (measured 1.4e-12, in s'': the switch time t_sw is the
      plant's accumulated time);
    * |att_ref| <= att_max, |qd_ref| <= qd_max (+1e-12) over the whole run, and the finite
      difference of qd_ref <= qdd_max + 1e-9 (measured: 0.298 / 0.3, 0.021 / 0.2,
      0.077 / 0.1); references()["q_dd"] = s'' f + 2 s' f' + s f'' to 1e-9 (measured 0) and
      within qdd_max.
    """
    p, ex, na, n = make_plant()
    p.set_excitation(1.0)
    k_req = 60                                   # t = 3.0 s
    rows = run(p, 240, {k_req: 4.0})
    t_req = k_req * DT
    T = np.array([r["t"] for r in rows])
    L = np.array([r["level_out"] for r in rows])
    R = np.array([r["rate_out"] for r in rows])
    # one change of the rate output, from 1 to 4, from a point with s = s' = s'' = 0
    changes = np.flatnonzero(np.diff(R) != 0.0)
    assert len(changes) == 1 and set(R) == {1.0, 4.0}
    i_sw = int(changes[0])                       # last point at the old rate
    assert R[i_sw] == 1.0 and R[i_sw + 1] == 4.0
    assert rows[i_sw]["lev"] == (0.0, 0.0, 0.0)
    t_sw = T[i_sw]
    assert t_req + RAMP - 1e-9 <= t_sw <= t_req + RAMP + DT + 1e-9
    # pending until the switch, then done
    assert all(r["rate"] == (1.0, 4.0) for r in rows[k_req:i_sw + 1])
    assert all(r["rate"] == (4.0, 4.0) for r in rows[i_sw + 1:])
    # back at 1 within 2 x ramp (+ one step) of the request, and it stays there
    back = np.flatnonzero((T > t_sw) & (L == 1.0))
    assert back.size and T[back[0]] <= t_req + 2 * RAMP + DT + 1e-9
    assert np.all(L[back[0]:] == 1.0)
    print(f"level 0 at t = {t_sw:.4f} s, back to 1 at t = {T[back[0]]:.4f} s "
          f"(request at {t_req} s)")

    tab1, tab4 = channels(ex, 1.0, na, n), channels(ex, 4.0, na, n)
    assert not np.allclose(tab1[na:, 0], tab4[na:, 0])          # the joints re-bounded
    assert np.array_equal(tab1[:na, 0], tab4[:na, 0])           # attitude amplitude kept
    err_before = err_after = err_lev = 0.0
    for i, r in enumerate(rows):
        t = r["t"]
        if i <= i_sw:
            tab = tab1
            lev = quintic(t, 0.0, 0.0, 1.0) if t <= t_req + 1e-9 else quintic(t, t_req, 1.0, 0.0)
        else:
            tab = tab4
            lev = quintic(t, t_sw, 0.0, 1.0)
        err_lev = max(err_lev, float(np.max(np.abs(np.subtract(r["lev"], lev)))))
        att, qd = expected_refs(tab, t, lev[0], lev[1], na)
        e = max(float(np.max(np.abs(r["att"] - att))), float(np.max(np.abs(r["qd"] - qd))))
        if i <= i_sw:
            err_before = max(err_before, e)
        else:
            err_after = max(err_after, e)
    print(f"refs vs NumPy: before the switch {err_before:.1e}, after {err_after:.1e}; "
          f"level vs quintic {err_lev:.1e}")
    assert err_lev < 1e-10
    assert err_before < TOL_REF and err_after < TOL_REF

    # bounds over the whole run (ramps and switch included)
    att = np.array([r["att"] for r in rows])
    qd = np.array([r["qd"] for r in rows])
    qdd_fd = np.diff(qd, axis=0) / np.diff(T)[:, None]
    print(f"max |att_ref| {np.abs(att).max():.4f} (<= {ex.att_max}), max |qd_ref| "
          f"{np.abs(qd).max():.4f} (<= {ex.qd_max}), max fd |qdd_ref| "
          f"{np.abs(qdd_fd).max():.4f} (<= {ex.qdd_max})")
    assert np.abs(att).max() <= ex.att_max + 1e-12
    assert np.abs(qd).max() <= ex.qd_max + 1e-12
    assert np.abs(qdd_fd).max() <= ex.qdd_max + TOL_FD
    # the analytic acceleration reference as well: s'' f + 2 s' f' + s f''
    p2, _, _, _ = make_plant()
    p2.set_excitation(1.0)
    worst = 0.0
    for k in range(240):
        if k == k_req:
            p2.set_excitation_rate(4.0)
        p2.advance(DT)
        s, sd, sdd = p2.excitation_level()
        tab = tab4 if p2.excitation_rate()[0] == 4.0 else tab1
        f, fd, fdd = f_and_derivs(tab, p2.t)
        ref = p2.references()
        qdd = (sdd * f + 2 * sd * fd + s * fdd)[na:]
        worst = max(worst, float(np.max(np.abs(ref["q_dd"] - qdd))))
        assert np.abs(ref["q_dd"]).max() <= ex.qdd_max + 1e-12
    print(f"references()['q_dd'] vs s'' f + 2 s' f' + s f'': {worst:.1e}")
    assert worst < TOL_REF


# ------------------------------------------------------------------------------------------------
# 3. refusals and cancellation
# ------------------------------------------------------------------------------------------------

BAD_RATES = (0.05, 0.0999, 11.0, 10.0001, -1.0, 0.0, math.nan, math.inf, -math.inf)


def test_bad_rates_are_refused_with_the_state_untouched():
    """Each bad rate raises ValueError and leaves the whole data block (checkpoint bytes)
    unchanged, both with the level settled and with a switch pending; the ends of the range
    (0.1, 10) are accepted."""
    p, _, _, _ = make_plant()
    p.set_excitation(1.0)
    p.advance(2.5)
    for phase in ("settled", "pending"):
        cp = p.checkpoint()
        for bad in BAD_RATES:
            with pytest.raises(ValueError):
                p.set_excitation_rate(bad)
            assert p.checkpoint() == cp, (phase, bad)
        if phase == "settled":
            p.set_excitation_rate(2.0)
            p.advance(0.5)
            assert p.excitation_rate() == (1.0, 2.0)
    for ok in (0.1, 10.0):
        p.set_excitation_rate(ok)
        assert p.excitation_rate() == (1.0, ok)


def test_asking_for_the_rate_in_effect_cancels_a_pending_switch():
    """Rate 2 asked for at t = 2.5 s (level 1), then 1 (the rate in effect) at t = 3.0 s while
    the level dips: nothing pending any more, the level returns to 1 without reaching 0, the
    rate output stays 1, and att_ref / qd_ref (level settled) are the own table's channels
    again (1e-9; measured 0: the same formula)."""
    p, ex, na, n = make_plant()
    p.set_excitation(1.0)
    p.advance(2.5)
    p.set_excitation_rate(2.0)
    p.advance(0.5)
    s_mid = p.excitation_level()[0]
    assert 0.0 < s_mid < 1.0 and p.excitation_rate() == (1.0, 2.0)      # dipping
    p.set_excitation_rate(1.0)
    assert p.excitation_rate() == (1.0, 1.0)
    rows = run(p, 80)
    assert all(r["rate"] == (1.0, 1.0) and r["rate_out"] == 1.0 for r in rows)
    assert min(r["level_out"] for r in rows) > 0.0
    settled = [r for r in rows if r["lev"] == (1.0, 0.0, 0.0)]
    # back at 1 within a ramp (+ one step) of the cancellation
    assert settled and settled[0]["t"] <= 3.0 + RAMP + DT + 1e-9
    tab1 = channels(ex, 1.0, na, n)
    err = 0.0
    for r in settled:
        att, qd = expected_refs(tab1, r["t"], 1.0, 0.0, na)
        err = max(err, float(np.max(np.abs(r["att"] - att))), float(np.max(np.abs(r["qd"] - qd))))
    print(f"after the cancellation: back to 1 at t = {settled[0]['t']:.3f} s, refs vs the own "
          f"table {err:.1e}")
    assert err < TOL_REF


# ------------------------------------------------------------------------------------------------
# 4. state round trip with a switch pending; bad excitation-state entries
# ------------------------------------------------------------------------------------------------

def pending_switch(rate: float):
    """A plant at level 1 (2.5 s in), 0.3 s after asking for ``rate`` (dipping), and its
    state."""
    p, _, _, _ = make_plant()
    p.set_excitation(1.0)
    p.advance(2.5)
    p.set_excitation_rate(rate)
    p.advance(0.3)
    return p, p.get_state()


def test_state_round_trip_with_a_switch_pending():
    """A state taken 0.3 s after asking for rate 0.5 (level 1, dipping) carries
    excite_rate = [level requested 1, rate in effect 1, rate requested 0.5]; running 5 s from it
    (the switch happens inside), restoring it into the same plant and into a fresh one and
    running again gives the same outputs to 1e-12 relative (measured 0)."""
    p, s = pending_switch(0.5)
    assert s["excite_rate"].tolist() == [1.0, 1.0, 0.5]
    assert s["excite_ramp"].shape == (4,) and s["excite_ramp"][3] == RAMP
    assert 0.0 < p.excitation_level()[0] < 1.0

    def go(plant):
        ys = []
        for _ in range(100):
            plant.advance(DT)
            ys.append(plant.output_vector())
        return np.array(ys)

    ref = go(p)
    rate_col = p.output_slices()["excite_rate"][0]
    assert ref[0, rate_col] == 1.0 and ref[-1, rate_col] == 0.5          # switched inside
    p.set_state(s)
    again = go(p)
    fresh, _, _, _ = make_plant()
    fresh.set_state(s)
    other = go(fresh)
    scale = np.maximum(1.0, np.abs(ref))
    d1 = float(np.max(np.abs(again - ref) / scale))
    d2 = float(np.max(np.abs(other - ref) / scale))
    print(f"round trip: same plant {d1:.1e}, fresh plant {d2:.1e}")
    assert d1 <= 1e-12 and d2 <= 1e-12


BAD_ENTRIES = [("excite_rate", 1, 0.0), ("excite_rate", 1, 11.0), ("excite_rate", 1, math.nan),
               ("excite_rate", 2, 0.0), ("excite_rate", 2, 11.0), ("excite_rate", 2, math.nan),
               ("excite_rate", 2, 0.05), ("excite_rate", 0, 2.0), ("excite_rate", 0, -0.1),
               ("excite_rate", 0, math.nan), ("excite_ramp", 3, 0.0), ("excite_ramp", 3, -1.0),
               ("excite_ramp", 3, math.inf), ("excite_ramp", 0, 1.5), ("excite_ramp", 1, 2.0),
               ("excite_ramp", 2, math.nan)]


@pytest.mark.parametrize("key, i, value", BAD_ENTRIES)
def test_set_state_refuses_bad_excitation_entries(key, i, value):
    """A bad entry of the excitation state (rates outside [0.1, 10] or NaN, levels outside
    [0, 1], ramp duration <= 0 or not finite, NaN start time) raises ValueError and leaves
    the plant's data block unchanged (checkpoint bytes); the unaltered state is accepted."""
    p, s = pending_switch(3.0)
    cp = p.checkpoint()
    bad = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in s.items()}
    bad[key][i] = value
    with pytest.raises(ValueError):
        p.set_state(bad)
    assert p.checkpoint() == cp
    p.set_state(s)                                   # the state itself is fine
    assert p.excitation_rate() == (1.0, 3.0)


# ------------------------------------------------------------------------------------------------
# 5. the FMUs: ident.excite_rate and excite.rate, both flavours
# ------------------------------------------------------------------------------------------------

FMU_PARAMS = {"excite.ramp": 1.0, "excite.period": 8.0}
FMU_DT = 0.25


@pytest.fixture(scope="module", params=["native"])
def plant_fmu(request, tmp_path_factory):
    from spacerobot.fmi.build import build_fmu

    sc = scenario("planar")
    path = build_fmu("plant", sc, tmp_path_factory.mktemp(f"rate_{request.param}"))
    return request.param, sc, path


def test_fmu_declares_the_rate_input_and_output(plant_fmu):
    from fmpy import read_model_description

    _, _, path = plant_fmu
    md = read_model_description(str(path))
    v = {x.name: x for x in md.modelVariables}
    assert v["ident.excite_rate"].causality == "input"
    assert float(v["ident.excite_rate"].start) == 1.0
    assert v["excite.rate"].causality == "output"
    for name in ("ident.excite_rate", "excite.rate"):
        assert v[name].type == "Real" and v[name].unit == "1", name


def test_fmu_rate_switches_through_the_dip_clips_and_discards(plant_fmu):
    """With ident.excite = 1 (level settled), ident.excite_rate = 4 then 20:

    * excite.rate and excite.level equal the core Plant run with the same requests to 1e-12
      (20 asked of the core as 10); excite.rate is 4 after the dip (back to level 1 within
      2 x ramp + one step), and 10 after the second dip; the value 20 is logged as a warning
      naming ident.excite_rate;
    * ident.excite_rate = NaN: fmi2DoStep returns fmi2Discard, the outputs are those before the
      call, and a step from the same time then goes on like the core (no communication-point
      warning; the native FMU's fmi2LastSuccessfulTime is that time).
    """
    from test_conformance_util import DISCARD, OK, WARNING, Inst

    backend, sc, path = plant_fmu
    ex = dataclasses.replace(sc.excitation, ramp=1.0, period=8.0)
    core = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h, ex)
    inst = Inst(path, f"rate-{backend}")
    try:
        inst.init(FMU_PARAMS)
        assert inst.get("ident.excite_rate") == 1.0 and inst.get("excite.rate") == 1.0
        t = 0.0
        levels, rates, worst = [], [], [0.0]

        def step(u_rate, core_rate):
            nonlocal t
            inst.set("ident.excite", 1.0)
            inst.set("ident.excite_rate", u_rate)
            n0 = len(inst.messages)
            st = inst.step(t, FMU_DT)
            core.set_excitation_rate(core_rate)
            core.set_excitation(1.0)
            core.advance(FMU_DT)
            t += FMU_DT
            o = core.outputs()
            lv, rt = inst.get("excite.level"), inst.get("excite.rate")
            assert lv == pytest.approx(float(o["excite_level"][0]), abs=1e-12), t
            assert rt == pytest.approx(float(o["excite_rate"][0]), abs=1e-12), t
            worst[0] = max(worst[0], abs(lv - float(o["excite_level"][0])),
                           abs(rt - float(o["excite_rate"][0])))
            levels.append(lv)
            rates.append(rt)
            return st, inst.messages[n0:]

        for _ in range(8):                                   # level 0 -> 1 (settled at 1 s)
            assert step(1.0, 1.0)[0] == OK
        assert levels[-1] == 1.0 and rates[-1] == 1.0
        k0 = len(rates)
        for _ in range(12):                                  # 3 s >= 2 x ramp + one step
            assert step(4.0, 4.0)[0] == OK
        assert rates[-1] == 4.0 and levels[-1] == 1.0
        # the rate output moved while the level was 0 (its last point at rate 1 had level 0)
        i = k0 + rates[k0:].index(4.0)
        assert levels[i - 1] == 0.0 and set(rates[k0:i]) == {1.0}
        assert (i + 1 - k0) * FMU_DT <= 2 * 1.0 + FMU_DT + 1e-9
        st, msgs = step(20.0, 10.0)
        assert st == WARNING or any(m[0] == WARNING for m in msgs)
        assert any(m[0] == WARNING and "ident.excite_rate" in m[2] and "20" in m[2]
                   for m in msgs), msgs
        for _ in range(11):
            step(20.0, 10.0)
        assert rates[-1] == 10.0 and levels[-1] == 1.0
        # NaN: discarded, state kept
        outs = inst.names("output")
        before = inst.values(outs)
        inst.set("ident.excite_rate", math.nan)
        st, msgs = inst.call(inst.step, t, FMU_DT)
        assert st == DISCARD
        assert any("ident.excite_rate" in m[2] and "NaN" in m[2] for m in msgs), msgs
        assert inst.values(outs) == before
        if backend == "native":
            from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Real
            import ctypes
            val = fmi2Real()
            assert inst.fmu.fmi2GetRealStatus(inst.fmu.component, fmi2LastSuccessfulTime,
                                              ctypes.byref(val)) == OK
            assert val.value == pytest.approx(t, abs=1e-12)
        st, msgs = step(10.0, 10.0)                          # same t: the plant time was kept
        assert st == OK and not [m for m in msgs if m[0] >= WARNING], msgs
        print(f"{backend} FMU: excite.level / excite.rate vs the core {worst[0]:.1e}; rate 4 "
              f"from t = {i * FMU_DT:.2f} s after the request at {k0 * FMU_DT:.2f} s")
    finally:
        inst.free()
