"""Propellant depletion in the plant (issue #17): the base = dry base + a tank whose content the
thrusters use (spacerobot.robots.Propellant, docs/models.md "Propellant").

* prop.m0 = 0 reproduces today's plant: the committed cross-check reference
  (fmu_plant/reference/planar, written before the propellant model existed), and bit for bit a
  plant built without a propellant argument, whatever the other propellant parameters are.
* Mass bookkeeping: the propellant (and base) mass at the end equals the initial mass minus the
  integral of the mass flow, summed here from the thrust the plant reports, to 1e-9 relative;
  also through a burn-out (the tank empties exactly, then the thrusters are silent).
* Momentum balance under the documented convention: the expelled propellant carries away
  prop.P, prop.L, and system.P + prop.P - P(0) = thrust.J, system.L + prop.L - L(0) =
  thrust.H, to the tolerance of the constant-base balance (tests/test_plant_physics.py); the
  balance without prop.P fails, so the term is not vacuous.
* The plant's dynamics (momentum, forward dynamics under its controls) with the base inertia
  updated from the propellant mass equal Pinocchio's with that base built from scratch
  (Pinocchio's own inertia addition is the oracle of the combined body).
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from oracles.pinocchio_model import build_model
from spacerobot.plant import Plant
from spacerobot.robots import G0, Propellant, RigidBody, scenario

ROOT = Path(__file__).resolve().parents[1]
REF = ROOT / "fmu_plant" / "reference" / "planar" / "SpaceRobotPlant_ref.csv"

#: a tank off the base's centre (planar robot: in the plane of motion, z = 0)
TANK = {"planar": (0.3, 0.2, 0.0), "spatial": (0.3, 0.2, -0.2)}

#: plant output keys of the constant-base plant (the interface before issue #17)
OLD_KEYS = ("r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd", "qdd", "F", "M", "J",
            "H", "P", "L", "tau", "excite_level", "att_ref", "qd_ref")


def make(robot: str, prop: Propellant | None, excite: float = 0.0) -> Plant:
    sc = scenario(robot)
    args = (sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
            sc.excitation)
    p = Plant(*args) if prop is None else Plant(*args, prop)
    if excite:
        p.set_excitation(excite)
    return p


def propellant(robot: str, m0: float) -> Propellant:
    return Propellant(m0=m0, Isp=220.0, r=TANK[robot], R=0.3, arm=1.0)


# -- prop.m0 = 0 is today's plant -------------------------------------------------------------

def test_zero_propellant_reproduces_the_committed_reference():
    """The planar cross-check reference (every column, 20 s at 0.1 s) from a plant with
    prop.m0 = 0 and other propellant parameters that would matter if the model were on."""
    with REF.open() as f:
        rows = list(csv.reader(f))
    names, ref = rows[0], np.array(rows[1:], float)
    col = {"base.r[1]": ("r_S", 0), "base.r[2]": ("r_S", 1), "base.v[1]": ("v_S", 0),
           "base.v[2]": ("v_S", 1), "base.omega[3]": ("omega_B", 2), "arm.q[1]": ("q", 0),
           "arm.q[2]": ("q", 1), "thrust.F[1]": ("F", 0), "thrust.M[3]": ("M", 2),
           "system.L[3]": ("L", 2)}
    assert set(names[1:]) <= set(col)
    p = make("planar", Propellant(m0=0.0, Isp=100.0, r=(1.0, -2.0, 0.5), R=0.7, arm=0.3))
    got = [p.outputs()]
    for _ in range(len(ref) - 1):
        p.advance(0.1)
        got.append(p.outputs())
    sim = np.array([[o[col[n][0]][col[n][1]] for n in names[1:]] for o in got])
    scale = np.maximum(np.abs(ref[:, 1:]).max(axis=0), 1.0)
    # the reference predates the compiled plant (#16), which reorders sums: 2e-12 of the scale
    assert np.max(np.abs(sim - ref[:, 1:]) / scale) <= 1e-11
    assert all(o["m_p"][0] == 0.0 and np.all(o["P_x"] == 0.0) for o in got)


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_zero_propellant_is_bit_for_bit_the_plant_without_propellant(robot):
    """Excitation on (every branch of the control law), 5 s in 0.1 s steps: every output of
    the constant-base interface identical, and the current-truth outputs equal the dry base."""
    a = make(robot, None, excite=1.0)
    b = make(robot, Propellant(m0=0.0, Isp=150.0, r=(0.4, -0.3, 0.2), R=0.5, arm=0.5),
             excite=1.0)
    dry = scenario(robot).robot.base
    for _ in range(50):
        a.advance(0.1)
        b.advance(0.1)
        oa, ob = a.outputs(), b.outputs()
        for k in OLD_KEYS:
            assert np.array_equal(oa[k], ob[k]), k
        assert np.array_equal(ob["base_now"], [dry.mass, *dry.com, *dry.inertia])


# -- mass bookkeeping --------------------------------------------------------------------------

def _flow(F, M, prop: Propellant) -> float:
    """|F_x| + |F_y| + |F_z| + (|M_x| + |M_y| + |M_z|) / arm, over Isp g0 (docs/models.md)."""
    return (sum(abs(f) for f in F) + sum(abs(m) for m in M) / prop.arm) / (prop.Isp * G0)


@pytest.mark.parametrize("robot,m0,T", [("spatial", 50.0, 3.0), ("planar", 50.0, 3.0),
                                        ("spatial", 0.05, 3.0)])
def test_end_mass_is_initial_mass_minus_integral_of_the_flow(robot, m0, T):
    """Communication step = internal step, so the thrust the plant reports is the thrust held
    over each step; the integral of the flow is summed here (math.fsum). The 0.05 kg tank
    empties after about 1.8 s: the step that empties it is scaled, later steps do not fire."""
    prop = propellant(robot, m0)
    p = make(robot, prop, excite=1.0)
    dry = scenario(robot).robot.base
    used = []
    for _ in range(int(round(T / p.h))):
        u = p.controls()
        used.append(_flow(u.F, u.M, prop) * p.h)
        p.advance(p.h)
    expected = m0 - math.fsum(used)
    assert abs(p.m_p - expected) <= 1e-9 * m0
    o = p.outputs()
    assert abs(o["base_now"][0] - (dry.mass + expected)) <= 1e-9 * (dry.mass + m0)
    assert o["m_p"][0] == p.m_p
    if m0 < 1.0:                                         # burn-out: empty and silent
        assert p.m_p == 0.0
        assert np.all(o["F"] == 0.0) and np.all(o["M"] == 0.0)
        assert used[-1] == 0.0 and used[0] > 0.0
    else:                                                # not vacuous: thrust all along
        assert m0 - p.m_p > 0.02                       # kg


# -- momentum balance ---------------------------------------------------------------------------

@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_momentum_balance_with_depletion(robot):
    """system.P + prop.P - P(0) = thrust.J and system.L + prop.L - L(0) = thrust.H at 1e-9 of
    the momentum (the constant-base tolerance), over 10 s of thrusting with excitation."""
    p = make(robot, propellant(robot, 80.0), excite=1.0)
    out = [p.outputs()]
    for _ in range(100):
        p.advance(0.1)
        out.append(p.outputs())
    P0, L0 = out[0]["P"], out[0]["L"]
    Lscale = max(np.linalg.norm(o["L"]) for o in out)
    eP = max(np.linalg.norm(o["P"] + o["P_x"] - P0 - o["J"]) for o in out) / np.linalg.norm(P0)
    eL = max(np.linalg.norm(o["L"] + o["L_x"] - L0 - o["H"]) for o in out) / Lscale
    # without the expelled momentum the balance is off by far more than the tolerance
    bare = max(np.linalg.norm(o["P"] - P0 - o["J"]) for o in out) / np.linalg.norm(P0)
    print(f"{robot}: depletion, |P + P_x - P0 - J|/|P0| = {eP:.2e}, "
          f"|L + L_x - L0 - H|/|L| = {eL:.2e}, without P_x {bare:.2e}")
    assert out[-1]["m_p"][0] < 80.0 - 0.1
    assert bare > 1e-6
    assert eP <= 1e-9
    assert eL <= 1e-9


# -- the combined base and the plant's dynamics -------------------------------------------------

def _oracle_base(dry: RigidBody, prop: Propellant, m_p: float) -> pin.Inertia:
    """Dry base + a solid sphere (inertia (2/5) m R^2) at the tank, added by Pinocchio."""
    sphere = pin.Inertia(m_p, np.array(prop.r, float), 0.4 * m_p * prop.R ** 2 * np.eye(3))
    return pin.Inertia(dry.mass, np.array(dry.com, float), dry.inertia_matrix()) + sphere


def test_combined_base_equals_pinocchio_inertia_addition():
    dry = scenario("spatial").robot.base
    prop = propellant("spatial", 100.0)
    for m_p in (0.0, 1e-3, 37.5, 100.0):
        got = prop.base(dry, m_p)
        ref = _oracle_base(dry, prop, m_p)
        assert got.mass == pytest.approx(ref.mass, rel=1e-15)
        np.testing.assert_allclose(got.com, ref.lever, rtol=0, atol=1e-15)
        np.testing.assert_allclose(got.inertia_matrix(), ref.inertia, rtol=0, atol=1e-12)
    assert prop.base(dry, 0.0) == dry


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_plant_dynamics_with_the_updated_base_inertia_equal_pinocchio(robot):
    """Along a depleting, excited run of the plant: its momentum outputs P, L and the
    accelerations of its controls (held thrust and joint torques) against Pinocchio on a model
    whose base is built from the combined body at the plant's propellant mass (the oracle
    above): Pinocchio's centroidal momentum and forward dynamics (ABA) at the plant's state."""
    sc = scenario(robot)
    prop = propellant(robot, 100.0)
    p = make(robot, prop, excite=1.0)
    dry_model = build_model(sc.robot, sc.robot.base, sc.target).model
    masses = []
    for _ in range(4):
        p.advance(0.75)
        q, v, m_p = p.q, p.v, p.m_p
        masses.append(m_p)
        model = build_model(sc.robot, sc.robot.base, sc.target).model
        model.inertias[1] = _oracle_base(sc.robot.base, prop, m_p)
        data = model.createData()
        # momentum about the inertial origin
        hg = pin.computeCentroidalMomentum(model, data, q, v)
        P = np.array(hg.linear)
        L = np.array(hg.angular) + np.cross(data.com[0], P)
        o = p.outputs()
        np.testing.assert_allclose(o["P"], P, rtol=0, atol=1e-10 * np.abs(P).max())
        np.testing.assert_allclose(o["L"], L, rtol=0, atol=1e-10 * np.abs(L).max())
        # forward dynamics under the held controls (the base's generalised force: the thrust
        # at S in the base frame)
        u = p.controls()
        A = o["A"]
        if sc.robot.planar:
            f_b = np.array([*(A.T @ u.F)[:2], u.M[2]])
        else:
            f_b = np.concatenate([A.T @ u.F, A.T @ u.M])
        ref = pin.aba(model, data, q, v, np.concatenate([f_b, u.tau]))
        # the plant's accelerations are those of its control law (tau from them by inverse
        # dynamics): ABA recovers them to the rounding amplified by M's conditioning (up to
        # 2e5 along the spatial run): within 100 eps cond(M) (measured along this run: up to
        # 53 eps cond(M))
        M = pin.crba(model, data, q)
        cond = np.linalg.cond(np.triu(M) + np.triu(M, 1).T)
        tol = max(1e-12, 100 * np.finfo(float).eps * cond)
        np.testing.assert_allclose(u.a, ref, rtol=0, atol=tol * np.abs(ref).max())
        # not vacuous: the dry base gives other accelerations
        dry = pin.aba(dry_model, dry_model.createData(), q, v, np.concatenate([f_b, u.tau]))
        assert np.abs(dry - ref).max() > 1e-6 * np.abs(ref).max()
    assert masses[-1] < masses[0] < 100.0                     # the tank empties along the run


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_base_truth_output_is_the_propellant_base(robot):
    """The plant's output ``base_now`` against Propellant.base (NumPy) as the
    tank empties; and the dry base exactly without propellant model."""
    prop = propellant(robot, 30.0)
    p = make(robot, prop, excite=1.0)
    dry = scenario(robot).robot.base
    for _ in range(4):
        p.advance(0.5)
        ref = prop.base(dry, p.m_p)
        got = p.outputs()["base_now"]
        want = np.array([ref.mass, *ref.com, *ref.inertia])
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13 * np.abs(want).max())
    assert p.m_p < 30.0 and got[0] != dry.mass                  # the tank really emptied
    q = make(robot, None, excite=1.0)
    q.advance(0.5)
    assert np.array_equal(q.outputs()["base_now"], [dry.mass, *dry.com, *dry.inertia])


def test_state_round_trip_keeps_the_propellant():
    p = make("spatial", propellant("spatial", 20.0), excite=1.0)
    p.advance(0.5)
    s = p.get_state()
    p.advance(0.5)
    ref = p.outputs()
    q = make("spatial", propellant("spatial", 20.0))
    q.set_state(s)
    q.advance(0.5)
    got = q.outputs()
    for k in ("m_p", "P_x", "L_x", "base_now", "P", "J"):
        assert np.array_equal(got[k], ref[k]), k


# -- the parameter set ---------------------------------------------------------------------------

def test_depletion_parameter_set_is_a_tracking_set():
    """Spatial, propellant on, excitation on, several minutes; its estimator settings are
    estimator parameters of the interface (always excite, forgetting factor below 1), written
    to the set's estimator file of the SSP (the others: the estimator's defaults)."""
    from spacerobot.interface import ExciteMode, estimator_vars
    from spacerobot.robots import NO_EXCITATION, PARAMETER_SETS, parameter_set_scenario
    from spacerobot.system.ssd import estimator_parameter_set

    assert "depletion" not in PARAMETER_SETS["planar"]
    sc = parameter_set_scenario("spatial", "depletion")
    assert sc.propellant.active and sc.excitation != NO_EXCITATION and sc.stop_time >= 180.0
    names = {v.name: v for v in estimator_vars(sc.robot, sc)}
    settings = dict(PARAMETER_SETS["spatial"]["depletion"].estimator)
    assert set(settings) <= set(names)
    assert settings["ident.excite_mode"] == ExciteMode.ALWAYS
    assert 0.0 < settings["lambda"] < 1.0
    # every set's file binds the estimator parameters any set has: the set's own values, the
    # estimator's defaults for the others (e.g. the realistic set's noise profile)
    bound = {n: v for n, _, v, _ in estimator_parameter_set("spatial", "depletion")}
    assert bound == {n: settings.get(n, names[n].start) for n in bound}
    assert set(settings) <= set(bound)
    assert {n: v for n, _, v, _ in estimator_parameter_set("spatial", "default")} == {
        n: names[n].start for n in bound}
    # thrust for the whole run: the initial drift is not damped within the stop time
    P0 = np.linalg.norm(np.array(sc.v0)) * (sc.robot.base.mass + sc.propellant.m0)
    assert P0 / (math.sqrt(3.0) * sc.controller.F_max) > sc.stop_time


# -- the depletion set in the SSP: plant and estimator settings ---------------------------------

@pytest.fixture(scope="module")
def spatial_system(tmp_path_factory, spatial_fmus):
    from spacerobot.system import ssd
    return ssd.build_system("spatial", tmp_path_factory.mktemp("sys17"), fmus=spatial_fmus)


def test_depletion_set_binds_the_estimator_settings_in_the_ssp(spatial_system):
    """The set's estimator settings (robots.DEPLETION_ESTIMATOR) come with the SSP: the .ssp
    binds resources/estimator/<set>.ssv to the estimator component; a named set replaces it
    with its own, another set brings back the FMU's defaults. fmpy's reader validates the
    package against the SSP 1.0 schemas and sees both bindings."""
    import fmpy.ssp.ssd
    from spacerobot import run_ssp
    from spacerobot.robots import DEPLETION_ESTIMATOR

    desc = fmpy.ssp.ssd.read_ssd(str(spatial_system["ssp"]), validate=True)
    est = next(e for e in desc.system.elements if e.name == "estimator")
    assert [b.source for b in est.parameterBindings] == ["resources/estimator/default.ssv"]
    want = dict(DEPLETION_ESTIMATOR)
    assert want == {"ident.excite_mode": 2, "lambda": 0.98, "ident.corr_lags": 50}
    dep = run_ssp(spatial_system["ssp"], parameter_set="depletion", stop_time=0.3,
                  progress=False)
    assert dep.data["estimator.lambda"][0] == 0.98
    assert dep.data["estimator.ident.excite_mode"][0] == 2
    assert dep.data["estimator.ident.corr_lags"][0] == 50
    assert dep.data["plant.prop.m"][0] == 80.0
    bound = run_ssp(spatial_system["ssp"], stop_time=0.3, progress=False)
    assert bound.data["estimator.lambda"][0] == 1.0
    assert bound.data["estimator.ident.excite_mode"][0] == 1
    assert bound.data["estimator.ident.corr_lags"][0] == 0
    # an explicit override still wins over the set
    over = run_ssp(spatial_system["ssp"], parameter_set="depletion", stop_time=0.3,
                   progress=False, overrides={"estimator.lambda": 0.99})
    assert over.data["estimator.lambda"][0] == 0.99
