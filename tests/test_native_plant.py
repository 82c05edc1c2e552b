"""The plant (native/src/plant.c through spacerobot.core.plant.NativePlant, the library's
spacerobot.plant.Plant) for the planar, spatial and 7-joint servicer robots with the excitation
at a fixed level and the propellant depleting, over 10 s, against independent computations
(the momentum balance with the expelled propellant: tests/test_depletion.py): at the states
reached, every
kinematic output from the state by the documented conventions, the momentum outputs and the
accelerations under the plant's controls against Pinocchio on a model with the base of that
instant (tests/oracles/pinocchio_model.py), base_now against Propellant.base, the bounds of the
controllers and of the excitation references; the initial state against the oracle's
conventions; bad input refused with a message naming the parameter (every parameter's range:
tests/test_plant_tables.py) and the plant unchanged after a refused or failed step; checkpoint,
rollback, save / restore reproducing a run."""
from __future__ import annotations

import copy
import ctypes
import importlib.util
import os
import pickle
import re
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from spacerobot.robots import DEPLETION_PROPELLANT, URDF_DIR, RigidBody, scenario

ROOT = Path(__file__).resolve().parents[1]
#: communication steps: multiples of h and not (the shorter last internal step); 0.4 s a cycle
STEPS = (0.1, 0.1, 0.0995, 0.1005)
DURATION = 10.0
LEVEL = 0.8


# -- the library --------------------------------------------------------------------------------

def _build_module():
    """native/build.py as a module."""
    spec = importlib.util.spec_from_file_location("_sr_native_build", ROOT / "native" / "build.py")
    build = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = build          # (its dataclasses look their module up)
    spec.loader.exec_module(build)
    return build


def _core_library(tmp_dir: Path) -> ctypes.CDLL:
    """$SPACEROBOT_CORE_LIB, else the installed library if it has the plant, else a fresh build
    of the plant's sources (native/build.py, warnings are errors)."""
    from spacerobot import core
    if os.environ.get("SPACEROBOT_CORE_LIB"):
        return core.load_library()
    try:
        lib = core.load_library()
        if hasattr(lib, "sr_plant_advance") and hasattr(lib, "sr_plant_controls"):
            return lib
    except (core.CoreUnavailable, OSError):
        pass
    build = _build_module()
    return core.load_library(build.build_library(tmp_dir, build.MODEL_SOURCES["plant"],
                                                    strict=True))


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return _core_library(tmp_path_factory.mktemp("plantlib"))


def _scenario(name: str):
    """(scenario, propellant) of a test case."""
    if name == "servicer7":
        return scenario(str(URDF_DIR / "servicer7.urdf")), DEPLETION_PROPELLANT
    if name == "spatial-empty":           # the tank empties within the run: thrust scaled, then 0
        return scenario("spatial"), replace(DEPLETION_PROPELLANT, m0=0.1)
    return scenario(name), DEPLETION_PROPELLANT


def _args(sc, prop):
    return (sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
            sc.excitation, prop)


def _run(plant, level=LEVEL, duration=DURATION):
    """Outputs (rows) and states along a run with the excitation level set at t = 0."""
    plant.set_excitation(level)
    ys, states = [plant.output_vector()], [plant.get_state()]
    t, k = 0.0, 0
    while t < duration - 1e-9:
        dt = STEPS[k % len(STEPS)]
        plant.advance(dt)
        t += dt
        k += 1
        ys.append(plant.output_vector())
        states.append(plant.get_state())
    return np.array(ys), states


CASES = ["planar", "spatial", "servicer7", "spatial-empty"]


@pytest.fixture(scope="module")
def runs(lib):
    """Per case: the slices, the native plant's run (outputs, states) and (scenario,
    propellant)."""
    from spacerobot.core.plant import NativePlant
    out = {}
    for name in CASES:
        sc, prop = _scenario(name)
        c = NativePlant(*_args(sc, prop), lib=lib)
        out[name] = (c.output_slices(), _run(c), (sc, prop))
    return out


def _split(y, slices):
    return {k: y[a:b].reshape(shape) for k, (a, b, shape) in slices.items()}


# -- the run really excites and depletes; the bounds ---------------------------------------------

@pytest.mark.parametrize("name", CASES)
def test_run_excites_depletes_and_keeps_its_bounds(runs, name):
    """The level reaches LEVEL, the references move within the excitation's bounds (|att_ref|
    <= att_max per axis, |qd_ref| <= qd_max), the thrust within F_max, M_max (eqs. 40-41,
    scaled down as the tank runs dry), the joint accelerations within qdd_max, and the tank
    empties (the spatial-empty case: to 0, then the thrusters are silent)."""
    slices, (yc, states), (sc, prop) = runs[name]
    assert abs(states[-1]["t"] - DURATION) < 1e-9
    g = {k: yc[:, a:b] for k, (a, b, _) in slices.items()}
    lv = g["excite_level"][:, 0]
    assert lv[-1] == pytest.approx(LEVEL) and lv[len(lv) // 2] > 0.0
    assert np.all((lv >= 0.0) & (lv <= LEVEL * (1 + 1e-12)))
    ex, c = sc.excitation, sc.controller
    assert np.max(np.abs(g["att_ref"])) > 1e-3
    assert np.max(np.abs(g["att_ref"])) <= ex.att_max * LEVEL * (1 + 1e-12)
    assert np.max(np.abs(g["qd_ref"])) <= ex.qd_max * (1 + 1e-12)
    assert np.max(np.abs(g["F"])) <= c.F_max * (1 + 1e-12)
    assert np.max(np.abs(g["M"])) <= c.M_max * (1 + 1e-12)
    assert np.max(np.abs(g["qdd"])) <= c.qdd_max * (1 + 1e-12)
    m_p = g["m_p"][:, 0]
    assert m_p[-1] < m_p[0] == prop.m0 and np.all(np.diff(m_p) <= 0.0)
    assert np.all(m_p >= -1e-15 * prop.m0)    # a dry tank may end a rounding below 0 (below)
    if name == "spatial-empty":           # the tank ran dry: the thrusters fell silent
        assert m_p[-1] == pytest.approx(0.0, abs=1e-12)
        assert np.all(g["F"][-1] == 0.0) and np.all(g["M"][-1] == 0.0)
    else:
        assert np.max(np.abs(g["F"])) == pytest.approx(c.F_max)  # the thrust saturated


def test_a_dry_tank_state_restores(lib):
    """The state of a plant whose tank ran dry (the spatial-empty run's steps) restores."""
    from spacerobot.core.plant import NativePlant
    sc, prop = _scenario("spatial-empty")
    c = NativePlant(*_args(sc, prop), lib=lib)
    _run(c)
    assert c.m_p <= 1e-15
    NativePlant(*_args(sc, prop), lib=lib).set_state(c.get_state())


def test_layout_and_initial_state_follow_the_conventions(lib):
    """The outputs' names and sizes (docs: the interface's plant outputs), and the initial
    state: base at the origin with identity attitude, arm at q_home at rest, the base velocity
    of v0 (inertial) and omega0 (base frame) by the oracle's conventions, J = H = 0, the full
    tank, excitation level 0."""
    from oracles.pinocchio_model import (base_generalised_velocity, build_model,
                                         initial_configuration)
    from spacerobot.core.plant import NativePlant
    for name in ("planar", "spatial"):
        sc, prop = _scenario(name)
        c = NativePlant(*_args(sc, prop), lib=lib)
        n = sc.robot.n_joints
        sizes = {"r_S": 3, "v_S": 3, "A": 9, "omega_B": 3, "a_S": 3, "alpha_B": 3, "q": n,
                 "qd": n, "qdd": n, "F": 3, "M": 3, "J": 3, "H": 3, "P": 3, "L": 3, "tau": n,
                 "excite_level": 1, "att_ref": 3, "qd_ref": n, "m_p": 1, "P_x": 3, "L_x": 3,
                 "base_now": 10, "excite_rate": 1, "flex_P": 3, "flex_L": 3, "flex_q": 4,
                 "flex_qd": 4, "slosh_x": 4, "slosh_v": 4}
        sl = c.output_slices()
        assert list(sl) == list(sizes)
        assert [b - a for a, b, _ in sl.values()] == list(sizes.values())
        assert sl["A"][2] == (3, 3) and len(c.output_vector()) == sum(sizes.values())
        pm = build_model(sc.robot, sc.robot.base, sc.target)
        q0 = initial_configuration(pm)
        v0, w0 = np.array(sc.v0, float), np.array(sc.omega0, float)
        if pm.planar:
            v0[2], w0[:2] = 0.0, 0.0
        vb = base_generalised_velocity(pm, q0, v0, w0)
        st = c.get_state()
        np.testing.assert_allclose(st["q"], q0, rtol=0, atol=1e-15)
        np.testing.assert_allclose(st["v"], np.r_[vb, np.zeros(n)], rtol=0, atol=1e-15)
        assert st["t"] == 0.0 and not st["J"].any() and not st["H"].any()
        np.testing.assert_array_equal(st["prop"], [prop.m0, 0, 0, 0, 0, 0, 0])
        assert c.m_p == prop.m0 and c.excitation_level() == (0.0, 0.0, 0.0)
        np.testing.assert_array_equal(c.q_home, sc.robot.q0)
        o = c.outputs()
        np.testing.assert_allclose(o["v_S"], v0, rtol=0, atol=1e-15)
        np.testing.assert_allclose(o["omega_B"], w0, rtol=0, atol=1e-15)
        assert not o["att_ref"].any() and not o["qd_ref"].any()


# -- momentum -----------------------------------------------------------------------------------

def _rot(q, planar):
    """DCM base -> inertial of the configuration (the oracle's conventions)."""
    from oracles.pinocchio_model import quat_to_R
    if planar:
        c, s = q[2:4] / np.hypot(q[2], q[3])
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return quat_to_R(*q[3:7])


@pytest.mark.parametrize("name", CASES)
def test_outputs_at_the_states_reached_against_pinocchio(lib, runs, name):
    """At the start, middle and end of the run: r_S, A, v_S, omega_B, q, qd from the state by
    the coordinate conventions; base_now = Propellant.base(dry, m_p); P, L (about the inertial
    origin) = Pinocchio's centroidal momentum, and dv/dt under the held controls (the thrust
    at S in the base frame, the joint torques) = Pinocchio's ABA, on the model with the base of
    that instant; a_S = A (dv_l/dt + omega x v_l), alpha_B, qdd the parts of dv/dt; tau the
    controls' torques; F, M the controls' thrust."""
    from oracles.pinocchio_model import build_model
    from spacerobot.core.plant import NativePlant
    slices, (yc, states), (sc, prop) = runs[name]
    probe = NativePlant(*_args(sc, prop), lib=lib)
    n, worst = sc.robot.n_joints, {}

    def close(key, got, want, scale=None, tol=1e-10):
        scale = max(np.max(np.abs(want)), 1e-300) if scale is None else scale
        err = float(np.max(np.abs(np.asarray(got) - np.asarray(want)))) / scale
        worst[key] = max(worst.get(key, 0.0), err)
        assert err <= tol, (name, key, got, want, tol)

    for i in (0, len(states) // 2, len(states) - 1):
        s, o = states[i], _split(yc[i], slices)
        q, v = s["q"], s["v"]
        planar, nb = sc.robot.planar, (3 if sc.robot.planar else 6)
        A = _rot(q, planar)
        close("A", o["A"], A, 1.0)
        close("r_S", o["r_S"], np.r_[q[:2], 0.0] if planar else q[:3], 1.0)
        vl = np.r_[v[:2], 0.0] if planar else v[:3]
        w = np.r_[0.0, 0.0, v[2]] if planar else v[3:6]
        close("v_S", o["v_S"], A @ vl)
        close("omega_B", o["omega_B"], w)
        close("q", o["q"], q[-n:])
        close("qd", o["qd"], v[-n:])
        bn = prop.base(sc.robot.base, float(o["m_p"][0]))
        close("base_now", o["base_now"], [bn.mass, *bn.com, *bn.inertia])
        pm = build_model(sc.robot, bn, sc.target)
        data = pm.model.createData()
        hg = pin.computeCentroidalMomentum(pm.model, data, q, v)
        P = np.array(hg.linear)
        L = np.array(hg.angular) + np.cross(data.com[0], P)
        close("P", o["P"], P)
        close("L", o["L"], L)
        # a restored state (a dry tank's m_p clipped from -1e-21 to 0: test_a_dry_tank_state_...)
        probe.set_state(dict(s, prop=np.r_[max(s["prop"][0], 0.0), s["prop"][1:]]))
        np.testing.assert_allclose(probe.output_vector(), yc[i], rtol=1e-15, atol=1e-15)
        u = probe.controls()
        close("F", o["F"], u.F, max(sc.controller.F_max, 1e-300))
        close("M", o["M"], u.M, max(sc.controller.M_max, 1e-300))
        close("tau", o["tau"], u.tau)
        f_b = np.r_[(A.T @ u.F)[:2], u.M[2]] if planar else np.r_[A.T @ u.F, A.T @ u.M]
        a = pin.aba(pm.model, data, q, v, np.r_[f_b, u.tau])
        # (the plant's dv/dt is its control law's, tau from it by inverse dynamics: ABA gets it
        # back to the rounding amplified by M's conditioning)
        M = pin.crba(pm.model, data, q)
        tol = max(1e-10, 1e-14 * np.linalg.cond(np.triu(M) + np.triu(M, 1).T))
        close("dv/dt", u.a, a, tol=tol)
        dvl = np.r_[a[:2], 0.0] if planar else a[:3]
        dw = np.r_[0.0, 0.0, a[2]] if planar else a[3:6]
        close("a_S", o["a_S"], A @ (dvl + np.cross(w, vl)), tol=tol)
        close("alpha_B", o["alpha_B"], dw, tol=tol)
        close("qdd", o["qdd"], a[nb:], tol=tol)
    print(name, {k: f"{e:.0e}" for k, e in worst.items()})


# -- bad input ----------------------------------------------------------------------------------

def _bad(sc, prop, **kw):
    args = dict(robot=sc.robot, base=sc.robot.base, target=sc.target, controller=sc.controller,
                v0=sc.v0, omega0=sc.omega0, h=sc.h, excitation=sc.excitation, propellant=prop)
    args.update(kw)
    return args


@pytest.mark.parametrize("change, words", [
    (lambda sc: {"target": replace(sc.target, mass=float("nan"))}, "target"),
    (lambda sc: {"base": replace(sc.robot.base, mass=-5.0)}, "base.m"),
    (lambda sc: {"target": replace(sc.target, mass=-1.0)}, "target.m"),
    (lambda sc: {"h": 0.0}, "h must be within [1e-06, 1] s, got 0.0"),
    (lambda sc: {"h": -1e-3}, "h must"),
    (lambda sc: {"h": float("nan")}, "h must"),
    (lambda sc: {"controller": replace(sc.controller, K_D=float("nan"))}, "K_D"),
    (lambda sc: {"controller": replace(sc.controller, F_max=-1.0)},
     "F_max must be within [0, 1e+09] N, got -1.0"),
    (lambda sc: {"target": replace(sc.target, mass=1e308)},
     "target.m must be within [1e-06, 1e+15] kg, got 1e+308"),
    (lambda sc: {"v0": (1.0, float("nan"), 0.0)}, "base.v0"),
    (lambda sc: {"omega0": (0.0, 0.0, float("inf"))}, "base.omega0"),
    (lambda sc: {"excitation": replace(sc.excitation, ramp=0.0)}, "excite.ramp"),
    (lambda sc: {"excitation": replace(sc.excitation, att_max=float("nan"))}, "excite.att_max"),
    (lambda sc: {"propellant": replace(DEPLETION_PROPELLANT, m0=-1.0)}, "prop.m0"),
    (lambda sc: {"propellant": replace(DEPLETION_PROPELLANT, Isp=float("nan"))}, "prop.Isp"),
    (lambda sc: {"propellant": replace(DEPLETION_PROPELLANT, r=(0.0, float("nan"), 0.0))},
     "prop.r"),
    (lambda sc: {"target": RigidBody(10.0, (0, 0, 0), (1.0, 1.0, 5.0, 0, 0, 0))}, "triangle"),
    (lambda sc: {"target": RigidBody(10.0, (0, 0, 0), (1.0, 1.0, 1.0, 2.0, 0, 0))},
     "positive definite"),
])
def test_bad_parameters_refused_with_a_message(lib, change, words):
    from spacerobot.core.plant import NativePlant
    sc = scenario("spatial")
    with pytest.raises(ValueError, match=re.escape(words)):
        NativePlant(**_bad(sc, DEPLETION_PROPELLANT, **change(sc)), lib=lib)


def _same_state(a: dict, b: dict) -> bool:
    return all(np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in a)


def test_refused_and_failed_steps_leave_the_plant_unchanged(lib):
    from spacerobot.core.plant import NativePlant
    sc, prop = _scenario("spatial")
    c = NativePlant(*_args(sc, prop), lib=lib)
    c.set_excitation(1.0)
    c.advance(0.5)
    before, y_before = c.get_state(), c.output_vector()
    for dt in (float("nan"), 0.0, -0.1, float("inf")):
        with pytest.raises(ValueError):
            c.advance(dt)
        assert _same_state(c.get_state(), before)
    for level in (float("nan"), -0.1, 1.5):
        with pytest.raises(ValueError):
            c.set_excitation(level)
        assert _same_state(c.get_state(), before)
    # a step that overflows to a non-finite state: refused, the plant as before the call
    fast = dict(before, v=before["v"] * 1e150)
    c.set_state(fast)
    with pytest.raises(FloatingPointError):
        c.advance(0.1)
    assert _same_state(c.get_state(), fast)
    # a state that does not fit is refused and leaves the plant as it was
    c.set_state(before)
    for bad in (dict(before, q=before["q"] * 2.0), dict(before, t=float("nan")),
                dict(before, prop=np.r_[prop.m0 * 2, np.zeros(6)]),
                dict(before, v=np.r_[before["v"][:-1], np.nan]), dict(before, q=before["q"][:-1])):
        with pytest.raises(ValueError):
            c.set_state(bad)
        assert _same_state(c.get_state(), before)
    np.testing.assert_array_equal(c.output_vector(), y_before)
    # and it still runs as a plant restored to that state does
    twin = NativePlant(*_args(sc, prop), lib=lib)
    twin.set_state(before)
    c.advance(0.3)
    twin.advance(0.3)
    np.testing.assert_array_equal(c.output_vector(), twin.output_vector())


# -- save / restore -----------------------------------------------------------------------------

def test_checkpoint_state_copy_and_pickle_reproduce_a_run(lib):
    from spacerobot.core.plant import NativePlant
    sc, prop = _scenario("servicer7")
    c = NativePlant(*_args(sc, prop), lib=lib)
    c.set_excitation(0.6)
    c.advance(1.05)
    cp, state = c.checkpoint(), c.get_state()
    twin, pick = copy.deepcopy(c), pickle.loads(pickle.dumps(c))
    fresh = NativePlant(*_args(sc, prop), lib=lib)
    fresh.set_state(state)

    def go(p):
        ys = []
        for dt in (0.1, 0.0995, 0.2, 0.1005):
            p.advance(dt)
            ys.append(p.output_vector())
        return np.array(ys)

    first = go(c)
    c.rollback(cp)
    assert _same_state(c.get_state(), state)
    for other in (c, twin, pick, fresh):
        np.testing.assert_array_equal(go(other), first)


@pytest.mark.slow
def test_mingw_compiles_the_plant_warning_free(tmp_path):
    cc = shutil.which("x86_64-w64-mingw32-gcc")
    if cc is None:
        pytest.skip("no x86_64-w64-mingw32-gcc")
    for name in _build_module().MODEL_SOURCES["plant"]:
        res = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-c",
                              str(ROOT / "native" / "src" / name), "-o", str(tmp_path / "p.o")],
                             capture_output=True, text=True)
        assert res.returncode == 0, (name, res.stderr)


def test_null_and_uninitialised_blocks_are_refused_without_a_crash(lib):
    from spacerobot.core import plant as cp
    L = cp._bind(lib)
    st_ok = cp.STATUS_OK
    zmodel = cp._block(L.sr_plant_model_size())          # zeroed: not initialised
    zdata = cp._block(L.sr_plant_data_size())
    y = np.empty(200)
    for m, d in ((None, None), (zmodel, None), (zmodel, zdata)):
        assert L.sr_plant_advance(m, d, 0.1) == cp.EARG
        assert L.sr_plant_outputs(m, d, cp.dptr(y)) == cp.EARG
        assert L.sr_plant_set_excitation(m, d, 0.5) == cp.EARG
        assert L.sr_plant_start(m, d) == cp.EARG
    assert L.sr_plant_model_init(None, None, None, None, None, None, None, None, None, None,
                                 1e-3, None, 0) == cp.EARG
    # a started model with a data block never started (all zero: no attitude) fails cleanly
    sc, prop = _scenario("planar")
    c = cp.NativePlant(*_args(sc, prop), lib=lib)
    assert L.sr_plant_advance(c._model, zdata, 0.1) != st_ok
    assert L.sr_plant_output_name(L.sr_plant_output_count()) is None
    assert L.sr_plant_output_name(-1) is None
