"""The plant's flexible parts (hinged panels, propellant slosh modes: native/src/plant_leaves.c,
the leaves of native/src/dynamics*.c) against independent computations:

* the rigid-body algorithms with leaves (ABA, CRBA, RNEA, momentum) against Pinocchio on
  random states of the planar, spatial and 7-joint servicer robots with random panels and
  slosh modes (tests/oracles/flexible_pinocchio.py);
* the plant at states it reached: the base's and the leaves' accelerations and the joint
  torques under its controls against Pinocchio's hybrid dynamics, the momentum, the flexible
  parts' momentum and the composite rigid base against Pinocchio; the controllers are the
  composite rigid body's (the thrust the bounded laws of the system's momentum, the joint
  accelerations those the rigid plant with the composite base commands at the same state);
* the momentum balance over a run with thrust and propellant (the slosh masses part of it,
  never drawn), the energy balance with the springs and dampers, the linearised frequencies
  against a simulated free vibration, the closed loop bounded with the issue's sizes;
* off by default: the plant with flex.n = slosh.n = 0 (whatever the records) is the rigid
  plant bit for bit; bad parameters refused with their names; the state round trip.
"""
from __future__ import annotations

import math
import pickle
from dataclasses import replace

import numpy as np
import pytest

from oracles import flexible_pinocchio as fp
from spacerobot.core.plant import NativePlant
from spacerobot.robots import (DEPLETION_PROPELLANT, NO_EXCITATION, PLANAR_PANELS, PLANAR_SLOSH,
                               ROBOTS, SPATIAL_PANELS, SPATIAL_SLOSH, URDF_DIR, Appendages,
                               Propellant, RigidBody, Slosh, get_robot, parameter_set_scenario,
                               plate_panel, scenario)

TOL = 1e-12


def _rel(a, b) -> float:
    """max |a - b| over max(1, max |b|)."""
    b = np.asarray(b, float)
    return float(np.max(np.abs(np.asarray(a, float) - b)) / max(1.0, np.max(np.abs(b))))


def _flexible(robot: str, flex: int = 2, slosh: int = 2, **change):
    """The scenario of ``robot`` (planar or spatial) with its default panels and slosh modes,
    the first ``flex`` and ``slosh`` of them in use, the flexible sets' gentle motion."""
    sc = parameter_set_scenario("spatial", "flexible") if robot == "spatial" else replace(
        scenario("planar"), v0=(0.3, -0.2, 0.0), omega0=(0.0, 0.0, 0.05))
    sc = replace(sc, flex=replace(sc.flex, n=flex), slosh=replace(sc.slosh, n=slosh))
    return replace(sc, **change)


# -- the rigid-body algorithms with leaves against Pinocchio ------------------------------------

def _random_parts(rng, planar: bool, n_flex: int, n_slosh: int):
    """Random panels (plates of random size, place and hinge axis; planar: hinged along z) and
    slosh modes (random mass, point and direction; planar: in the plane)."""
    panels, modes = [], []
    for _ in range(n_flex):
        axis = (0.0, 0.0, 1.0) if planar else rng.normal(size=3)
        axis = np.asarray(axis) / np.linalg.norm(axis)
        out = np.cross(axis, rng.normal(size=3))
        p = plate_panel(rng.uniform(5.0, 60.0), rng.normal(scale=0.6, size=3), out, axis,
                        rng.uniform(0.5, 4.0), rng.uniform(0.3, 2.0), rng.uniform(0.01, 0.1),
                        f=rng.uniform(0.2, 2.0), zeta=rng.uniform(0.0, 0.05))
        panels.append(p)
    for _ in range(n_slosh):
        d = rng.normal(size=3)
        if planar:
            d[2] = 0.0
        modes.append(replace(SPATIAL_SLOSH[0], m=rng.uniform(2.0, 40.0),
                             r=tuple(rng.normal(scale=0.4, size=3)), axis=tuple(d),
                             f=rng.uniform(0.1, 1.0)))
    return panels, modes


@pytest.fixture(scope="module")
def dyn_lib():
    import ctypes

    from spacerobot.core import lib as core_lib
    from spacerobot.core import robot_record as rr
    from test_native_dynamics import bind
    L = bind(core_lib())
    L.sr_dyn_add_leaf.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(ctypes.c_double),
                                  ctypes.POINTER(ctypes.c_double), ctypes.POINTER(rr.SrBody)]
    return L


@pytest.mark.parametrize("name", ["planar", "spatial", "servicer7"])
def test_leaves_in_the_rigid_body_algorithms_equal_pinocchio(dyn_lib, name):
    import ctypes

    import pinocchio as pin

    from oracles.pinocchio_model import random_state
    from spacerobot.core import robot_record as rr
    from test_native_dynamics import TARGET, Dyn, P, _sr_body
    L = dyn_lib
    robot = get_robot(str(URDF_DIR / "servicer7.urdf")) if name == "servicer7" else ROBOTS[name]
    rng = np.random.default_rng(38)
    worst = dict(aba=0.0, M=0.0, nle=0.0, hg=0.0, com=0.0)
    for trial in range(4):
        panels, modes = _random_parts(rng, robot.planar, 1 + trial % 4, 4 - trial)
        fm = fp.build(robot, robot.base, TARGET, panels, modes)
        dyn = Dyn(L, rr.c_robot(robot, L), _sr_body(TARGET))
        for p in panels:
            b = _sr_body(p.body())
            assert L.sr_dyn_add_leaf(dyn.model, 0, P(np.array(p.hinge)), P(np.array(p.axis)),
                                     ctypes.byref(b)) == 0
        for s in modes:
            b = _sr_body(RigidBody(s.m, s.r, (0.0,) * 6))
            assert L.sr_dyn_add_leaf(dyn.model, 1, None, P(np.array(s.axis, float)),
                                     ctypes.byref(b)) == 0
        dyn.nv, dyn.nq = fm.model.nv, fm.model.nq
        for _ in range(5):
            q, v, tau = random_state(fm.model, rng)     # strokes and deflections up to pi
            worst["aba"] = max(worst["aba"], _rel(dyn.aba(q, v, tau),
                                                  pin.aba(fm.model, fm.data, q, v, tau)))
            M, nle, hg, com = dyn.terms(q, v)
            pin.computeAllTerms(fm.model, fm.data, q, v)
            Mref = np.triu(fm.data.M) + np.triu(fm.data.M, 1).T
            worst["M"] = max(worst["M"], float(np.max(np.abs(M - Mref)) / np.max(np.abs(Mref))))
            worst["nle"] = max(worst["nle"], _rel(nle, fm.data.nle))
            worst["hg"] = max(worst["hg"], _rel(hg, fm.data.hg.vector))
            worst["com"] = max(worst["com"], _rel(com, fm.data.com[0]))
    print(name, {k: f"{x:.1e}" for k, x in worst.items()})
    assert max(worst.values()) <= TOL, worst
    # the physical-state functions know no leaves: refused
    z3, A = np.zeros(3), np.eye(3)
    qa = np.zeros(robot.n_joints)
    assert L.sr_dyn_momentum(dyn.model, dyn.data, *map(P, (z3, A.ravel().copy(), z3, z3, qa, qa,
                                                           z3.copy(), z3.copy(), None))) == 1


# -- the plant at the states it reaches against Pinocchio -----------------------------------------

def _oracle_at(plant: NativePlant, sc):
    """The oracle's model of the plant at its current propellant: the leaf model's base is the
    dry base plus the rigid part of the propellant (m_p less the slosh masses)."""
    prop = sc.propellant
    m_slosh = sum(s.m for s in sc.slosh.active) if prop.active else 0.0
    base = fp.with_tank(sc.robot.base, plant.m_p - m_slosh, prop.r, prop.R)
    return fp.build(sc.robot, base, sc.target, sc.flex.active, sc.slosh.active)


@pytest.mark.parametrize("case", ["spatial", "spatial+propellant", "planar"])
def test_plant_against_pinocchio_at_the_states_it_reaches(case):
    import pinocchio as pin
    robot = case.split("+")[0]
    sc = _flexible(robot)
    if "propellant" in case:
        sc = replace(sc, propellant=DEPLETION_PROPELLANT)
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    ctrl = sc.controller
    worst = dict(acc=0.0, tau=0.0, P=0.0, L=0.0, flex=0.0, truth=0.0, thrust=0.0)
    deflected = 0.0
    for k in range(8):
        plant.advance(1.7 if k % 2 else 1.0005)
        y = plant.outputs()
        c = plant.controls()
        st = plant.get_state()
        q, v = st["q"], st["v"]
        fm = _oracle_at(plant, sc)
        au, tau = fp.hybrid(fm, q, v, c.a[fm.arm], c.F, c.M)
        worst["acc"] = max(worst["acc"], _rel(c.a[fm.u], au))
        worst["tau"] = max(worst["tau"], _rel(c.tau, tau))
        P, L = fp.momentum(fm, q, v)
        Pr, Lr = fp.momentum(fm, q, v, rigid=True)
        scale = max(1.0, np.abs(L).max())
        worst["P"] = max(worst["P"], _rel(y["P"], P))
        worst["L"] = max(worst["L"], _rel(y["L"], L))
        worst["flex"] = max(worst["flex"], _rel(y["flex_P"], P - Pr),
                            float(np.abs(y["flex_L"] - (L - Lr)).max()) / scale)
        comp = fp.composite(fm)                  # the leaf model's base (+ tank) + the leaves
        worst["truth"] = max(worst["truth"], _rel(y["base_now"], comp))
        # the thrusters: the bounded laws (K < 0) of the system's momentum, P and L about its
        # centre of mass
        pin.centerOfMass(fm.model, fm.data, q)
        Lc = L - np.cross(fm.data.com[0], P)
        F = np.where(np.abs(P) >= ctrl.P_max, -np.sign(P) * ctrl.F_max,
                     np.clip(ctrl.K_F * P, -ctrl.F_max, ctrl.F_max))
        Mt = np.where(np.abs(Lc) >= ctrl.L_max, -np.sign(Lc) * ctrl.M_max,
                      np.clip(ctrl.K_M * Lc, -ctrl.M_max, ctrl.M_max))
        worst["thrust"] = max(worst["thrust"], _rel(c.F, F), _rel(c.M, Mt))
        deflected = max(deflected, np.abs(y["flex_q"]).max(), np.abs(y["slosh_x"]).max())
    print(case, {k: f"{x:.1e}" for k, x in worst.items()}, f"deflection {deflected:.3g}")
    assert deflected > 1e-3                          # the parts moved
    assert max(worst[k] for k in ("acc", "tau", "P", "L", "flex", "truth")) <= TOL, worst
    assert worst["thrust"] <= 1e-9, worst


@pytest.mark.parametrize("robot", ["spatial", "planar"])
def test_the_arm_is_commanded_on_the_composite_rigid_body(robot):
    """The joint accelerations the flexible plant commands are those the rigid plant with the
    composite base (the panels at rest, the slosh masses at equilibrium) commands at the same
    base and arm state and excitation (thrusters off in both, so that the thrust is the same);
    the rigid plant differs from the flexible one's truth by the parts' motion."""
    sc = _flexible(robot, controller=replace(scenario(robot).controller, F_max=0.0, M_max=0.0))
    flex = NativePlant.of(sc)
    flex.set_excitation(1.0)
    flex.advance(6.3)
    st = flex.get_state()
    comp = flex.base_now()
    rigid = NativePlant.of(replace(sc, flex=Appendages(), slosh=Slosh()), base=comp)
    nq0, nb, n = (4, 3, sc.robot.n_joints) if sc.robot.planar else (7, 6, sc.robot.n_joints)
    rigid.set_state({**st, "q": st["q"][:nq0 + n], "v": st["v"][:nb + n]})
    a_flex, a_rigid = flex.controls().a, rigid.controls().a
    print(robot, f"qdd {_rel(a_flex[nb:nb + n], a_rigid[nb:]):.1e}, base acceleration "
                 f"{_rel(a_flex[:nb], a_rigid[:nb]):.1e} apart")
    assert np.abs(st["q"][nq0 + n:]).max() > 1e-4             # the parts are deflected
    assert _rel(a_flex[nb:nb + n], a_rigid[nb:]) <= 1e-10
    assert _rel(a_flex[:nb], a_rigid[:nb]) > 1e-6           # the base responds to the parts


# -- balances and frequencies --------------------------------------------------------------------

@pytest.mark.slow
def test_momentum_balance_with_thrust_and_the_slosh_part_of_the_propellant():
    """P + P_x - P(0) = J and L + L_x - L(0) = H over 60 s of thrust with the propellant used
    (the expelled propellant carries P_x, L_x away), to 1e-9 of the momentum change; the slosh
    masses (50 kg) are part of the 50.5 kg of propellant and never drawn: the thrusters stop
    once the 0.5 kg of the rigid part are used, and the tank stays at the slosh masses."""
    prop = replace(DEPLETION_PROPELLANT, m0=50.5)
    sc = _flexible("spatial", propellant=prop)
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    y0 = plant.outputs()
    P0, L0 = y0["P"].copy(), y0["L"].copy()
    dP = dL = eP = eL = 0.0
    silent = None
    for k in range(600):
        plant.advance(0.1)
        y = plant.outputs()
        dP, dL = max(dP, np.abs(y["P"] - P0).max()), max(dL, np.abs(y["L"] - L0).max())
        eP = max(eP, np.abs(y["P"] + y["P_x"] - P0 - y["J"]).max())
        eL = max(eL, np.abs(y["L"] + y["L_x"] - L0 - y["H"]).max())
        assert y["m_p"][0] >= 50.0
        if silent is None and y["m_p"][0] == 50.0:
            silent = k
        if silent is not None:
            assert np.all(y["F"] == 0.0) and np.all(y["M"] == 0.0)
    print(f"P {eP / dP:.1e} L {eL / dL:.1e} (|dP| {dP:.3g} N s, |dL| {dL:.3g} N m s), "
          f"tank at the slosh masses after {silent / 10 if silent else None} s")
    assert silent is not None and silent < 590
    assert eP <= 1e-9 * dP and eL <= 1e-9 * dL
    m_p = plant.m_p
    assert plant.base_now().mass == pytest.approx(sc.robot.base.mass + m_p + 100.0, rel=1e-15)


@pytest.mark.slow
def test_energy_balance_with_springs_and_dampers():
    """E - E(0) = W - D over 20 s: E the kinetic energy (Pinocchio's mass matrix) plus the
    springs', W the work of the joint torques and the thrust (held over each 1 ms step: tau .
    dq and F . dr_S exactly, M . omega by the trapezoid rule), D the dampers' dissipation
    c qd^2 (trapezoid rule); to 1e-6 of the largest |E - E(0)|."""
    sc = _flexible("spatial")
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    fm = fp.build(sc.robot, sc.robot.base, sc.target, sc.flex.active, sc.slosh.active)
    nb, n = fm.nb, fm.pm.n
    h = sc.h

    def sample():
        """q, v, the controls held from now, E, the dissipation rate, omega (inertial), r_S"""
        st = plant.get_state()
        y = plant.outputs()
        q, v = st["q"], st["v"]
        return (q, plant.controls(), fp.energy(fm, q, v), float(fm.c @ (v[nb + n:] ** 2)),
                y["A"] @ y["omega_B"], y["r_S"].copy())

    q0, c0, E0, d0, w0, r0 = sample()
    W = D = dE = err = 0.0
    for _ in range(int(round(20.0 / h))):
        plant.advance(h)
        q1, c1, E1, d1, w1, r1 = sample()
        W += float(c0.tau @ (q1[7:7 + n] - q0[7:7 + n]) + c0.F @ (r1 - r0)
                   + c0.M @ (0.5 * h * (w0 + w1)))
        D += 0.5 * h * (d0 + d1)
        dE = max(dE, abs(E1 - E0))
        err = max(err, abs(E1 - E0 - W + D))
        q0, c0, d0, w0, r0 = q1, c1, d1, w1, r1
    print(f"energy balance {err / dE:.1e} of max |E - E0| {dE:.4g} J; dissipated {D:.4g} J")
    assert D > 1e-4 * dE                           # the dampers took a part
    assert err <= 1e-6 * dE


@pytest.mark.slow
def test_linearised_frequencies_equal_a_simulated_free_vibration():
    """The arm held (qdd_max = 0), the thrusters off, no damping, no initial base motion,
    small initial deflections and strokes (0.06 degree, 5 mm: the frequencies shift with the
    amplitude squared, 2e-5 at 0.23 degree): the frequencies of the simulated free vibration
    of the deflections and strokes (matrix pencil over 60 s) equal those of the system
    linearised about its equilibrium with the base free (Pinocchio's mass matrix, the springs
    of the specification) to 1e-5; and those lie above the cantilevered ones (the base moves
    with the parts)."""
    base = _flexible("spatial")
    panels = tuple(replace(p, zeta=0.0, q0=q0) for p, q0 in zip(base.flex.panels,
                                                                 (0.001, -0.0005, 0, 0)))
    modes = tuple(replace(s, zeta=0.0, x0=x0) for s, x0 in zip(base.slosh.modes,
                                                               (0.005, 0.0025, 0, 0)))
    sc = replace(base, flex=Appendages(2, panels), slosh=Slosh(2, modes), v0=(0.0,) * 3,
                 omega0=(0.0,) * 3, excitation=NO_EXCITATION,
                 controller=replace(base.controller, F_max=0.0, M_max=0.0, qdd_max=0.0))
    plant = NativePlant.of(sc)
    fm = fp.build(sc.robot, sc.robot.base, sc.target, sc.flex.active, sc.slosh.active)
    q_rest = plant.q
    q_rest[-fm.nl:] = 0.0                            # about the equilibrium: the parts at rest
    f_lin = fp.linear_frequencies(fm, q_rest)
    dt = 0.05
    rows = []
    for _ in range(int(round(60.0 / dt)) + 1):
        y = plant.outputs()
        rows.append(np.r_[y["flex_q"][:2], y["slosh_x"][:2]])
        plant.advance(dt)
    f_sim, _ = fp.matrix_pencil(np.array(rows), dt, 2 * fm.nl)
    f_sim = f_sim[1::2]
    print("linearised", np.round(f_lin, 6), "simulated", np.round(f_sim, 6),
          f"relative {np.abs(f_sim / f_lin - 1).max():.1e}")
    assert np.abs(f_sim / f_lin - 1.0).max() <= 1e-5
    cantilevered = np.sort([0.5, 0.5, 0.30, 0.35])
    assert np.all(f_lin > cantilevered * (1 + 1e-3))


@pytest.mark.slow
def test_closed_loop_is_bounded_and_settles_with_the_issues_sizes():
    """The `flexible` set (two 50 kg wings at 0.5 Hz, 2 x 25 kg slosh at 0.30 / 0.35 Hz) for
    300 s with the excitation on: the deflections, strokes and the parts' momentum stay of the
    issue's sizes (wings within 2 degrees, slosh within 0.3 m, momentum within 20 N s and
    100 N m s); with the excitation off after 150 s they decay (the last 30 s below a tenth
    of the excited peak)."""
    sc = parameter_set_scenario("spatial", "flexible")
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    peak = np.zeros(4)
    late = np.zeros(4)
    for k in range(3000):
        if k == 1500:
            plant.set_excitation(0.0)
        plant.advance(0.1)
        y = plant.outputs()
        now = np.array([np.degrees(np.abs(y["flex_q"]).max()), np.abs(y["slosh_x"]).max(),
                        np.abs(y["flex_P"]).max(), np.abs(y["flex_L"]).max()])
        peak = np.maximum(peak, now)
        if k >= 2700:
            late = np.maximum(late, now)
    print("peak (deg, m, N s, N m s)", np.round(peak, 3), "last 30 s", np.round(late, 4))
    assert np.all(peak <= [2.0, 0.3, 20.0, 100.0])
    assert np.all(late <= 0.1 * peak)


# -- off by default, bad parameters, state -------------------------------------------------------

def test_no_parts_in_use_is_the_rigid_plant_bit_for_bit():
    """flex.n = slosh.n = 0 with records of other values (checked, then unused): every output
    of the depletion set with the excitation and a change of rate, 30 s, equals the plant's
    without flexible parts bit for bit (one binary), the parts' outputs are 0 and the truth
    is the dry base plus the propellant."""
    sc = parameter_set_scenario("spatial", "depletion")
    other = Appendages(0, tuple(replace(p, m=2 * p.m, f=0.8 * p.f) for p in SPATIAL_PANELS))
    slosh = Slosh(0, tuple(replace(s, m=3.0 * s.m) for s in SPATIAL_SLOSH))
    a = NativePlant.of(sc, flex=Appendages(), slosh=Slosh())
    b = NativePlant.of(sc, flex=other, slosh=slosh)
    for p in (a, b):
        p.set_excitation(1.0)
    keys = [k for k in a.outputs() if k.startswith(("flex_", "slosh_"))]
    for k in range(300):
        if k == 100:
            a.set_excitation_rate(2.0)
            b.set_excitation_rate(2.0)
        a.advance(0.1)
        b.advance(0.1)
        ya, yb = a.output_vector(), b.output_vector()
        assert np.array_equal(ya, yb)
    out = b.outputs()
    assert all(np.all(out[k] == 0.0) for k in keys)
    assert b.base_now() == sc.propellant.base(sc.robot.base, b.m_p)
    assert a.get_state()["q"].shape == (7 + 6,)


@pytest.mark.parametrize("change, message", [
    (dict(flex=Appendages(5)), "flex.n must be within [0, 4], got 5"),
    (dict(slosh=Slosh(-1)), "slosh.n must be within [0, 4], got -1"),
    (dict(flex=Appendages(2, (SPATIAL_PANELS[0], replace(SPATIAL_PANELS[1],
                                                         axis=(0.0, 0.0, 0.0))))),
     "flex.axis[2] must not be zero"),
    (dict(flex=Appendages(1, (replace(SPATIAL_PANELS[0], Izz=200.0),))),
     "flex[1] inertia violates the triangle inequality"),
    (dict(flex=Appendages(1, (replace(SPATIAL_PANELS[0], f=50.0),))),
     "flex.f[1] = 50.0 Hz is too fast for the step h = 0.001 s"),
    (dict(slosh=Slosh(2), propellant=replace(DEPLETION_PROPELLANT, m0=30.0)),
     "slosh.m: the slosh masses in use total 50 kg, more than the propellant prop.m0 = 30 kg"),
    (dict(flex=Appendages(0, (replace(SPATIAL_PANELS[0], zeta=1.5),))),
     "flex.zeta[1] must be within [0, 1] 1, got 1.5"),
    (dict(slosh=Slosh(0, SPATIAL_SLOSH[:3] + (replace(SPATIAL_SLOSH[3], r=(0.0, 2e3, 0.0)),))),
     "slosh.r[4,2] must be within [-1000, 1000] m, got 2000.0"),
])
def test_bad_parameters_are_refused_with_their_names(change, message):
    sc = _flexible("spatial", flex=0, slosh=0)
    with pytest.raises(ValueError) as exc:
        NativePlant.of(sc, **change)
    assert message in str(exc.value), str(exc.value)


@pytest.mark.parametrize("change, message", [
    (dict(flex=Appendages(1, PLANAR_PANELS[:1] + (replace(PLANAR_PANELS[1], axis=(0.0, 1.0, 0.0)),))),
     None),
    (dict(flex=Appendages(2, (PLANAR_PANELS[0], replace(PLANAR_PANELS[1], axis=(0.0, 1.0, 0.0))))),
     "flex.axis[2]: a planar robot's panels turn in its plane: the hinge axis must be along z"),
    (dict(slosh=Slosh(1, (replace(PLANAR_SLOSH[0], axis=(1.0, 0.0, 0.5)),))),
     "slosh.axis[1]: a planar robot's slosh masses move in its plane"),
])
def test_a_planar_robot_takes_parts_in_its_plane_only(change, message):
    sc = _flexible("planar", flex=0, slosh=0)
    if message is None:
        NativePlant.of(sc, **change)                 # a part out of the plane, not in use
        return
    with pytest.raises(ValueError) as exc:
        NativePlant.of(sc, **change)
    assert message in str(exc.value), str(exc.value)


def test_state_round_trip_checkpoint_and_pickle_with_leaves():
    """get_state / set_state, checkpoint / rollback and a pickled copy continue a run with
    panels, slosh and propellant exactly as the original does."""
    sc = _flexible("spatial", propellant=DEPLETION_PROPELLANT)
    p = NativePlant.of(sc)
    p.set_excitation(1.0)
    p.advance(3.0)
    st, cp, clone = p.get_state(), p.checkpoint(), pickle.loads(pickle.dumps(p))
    assert st["q"].shape == (7 + 6 + 4,) and st["v"].shape == (6 + 6 + 4,)
    p.advance(2.0)
    want = p.output_vector()
    for restore in (lambda: p.set_state(st), lambda: p.rollback(cp)):
        restore()
        p.advance(2.0)
        assert np.array_equal(p.output_vector(), want)
    clone.advance(2.0)
    assert np.array_equal(clone.output_vector(), want)
    bad = dict(st, prop=np.r_[49.0, st["prop"][1:]])          # below the slosh masses
    with pytest.raises(ValueError, match="propellant mass outside"):
        p.set_state(bad)
