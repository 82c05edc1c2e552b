"""Physics of the plant core: invariants, and Pinocchio cross-checked against independent
computations.

* Thrusters off: total linear and angular momentum (about the inertial origin) conserved.
* Thrusters on: P(t) - P(0) = J(t) and L(t) - L(0) = H(t) (impulse-momentum theorem).
* Pinocchio's momentum and accelerations agree with a plain-numpy sum over the bodies
  (the test oracle ``tests/oracles/kinematics.py``, which does not use Pinocchio), at random
  states built from physical quantities by this test (its own inverse of the plant's
  coordinate conventions).
* Measured accelerations are the time derivatives of the measured velocities.
* RK4: one step's error in the invariants is O(dt^5).
* The base attitude follows eq. 39 while the thrusters damp the momentum at F_max.
* A communication step that is not a multiple of h ends with one shorter RK4 step.

Runs are shared between assertions (module-scoped fixtures) and last only as long as needed.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from oracles.kinematics import ArmKinematics, body_momentum
from spacerobot.plant import Plant
from spacerobot.robots import scenario

RNG_SEED = 20201


def make_plant(robot: str, controller=None, h=None) -> tuple:
    sc = scenario(robot)
    c = sc.controller if controller is None else controller
    p = Plant(sc.robot, sc.robot.base, sc.target, c, sc.v0, sc.omega0, sc.h if h is None else h)
    return sc, p


def record(p: Plant, T: float, dt: float, keep_states=()):
    """Advance ``p`` to ``T`` in steps ``dt``; outputs at every sample, states at ``keep_states``."""
    out = [(p.t, p.outputs())]
    states = []
    keep = sorted(keep_states)
    for _ in range(int(round(T / dt))):
        p.advance(dt)
        out.append((p.t, p.outputs()))
        if keep and abs(p.t - keep[0]) < 1e-9:
            states.append(p.get_state())
            keep.pop(0)
    return out, states


def rel_dev(series, ref, scale):
    return max(np.linalg.norm(x - ref) for x in series) / scale


# ------------------------------------------------------------------------------------------------
# thrusters off: conservation
# ------------------------------------------------------------------------------------------------

#: Internal step of the free runs. With the thrusters off the spatial system keeps its
#: ~480 N m s about the CoM, which the arm cannot hold: the arm law then drives the base to
#: ~2 rad/s and the joints to ~5 rad/s, and at the paper's h = 1 ms RK4 truncation makes L drift
#: 3.3e-9 in 20 s. At h = 0.5 ms it stays below 1e-9 (the bound of issue #2); that the drift is
#: truncation and not a leak is checked by test_free_run_spatial_drift_is_truncation_error.
#: The planar run stays at round-off (1e-13) at h = 1 ms.
FREE_RUN_H = {"planar": 1e-3, "spatial": 5e-4}


@functools.lru_cache(maxsize=None)
def _free_run(robot):
    """Thrusters off, 20 s, outputs every 0.5 s (computed once per session and robot)."""
    sc = scenario(robot)
    off = dataclasses.replace(sc.controller, F_max=0.0, M_max=0.0)
    sc, p = make_plant(robot, off, h=FREE_RUN_H[robot])
    out, _ = record(p, 20.0, 0.5)
    return robot, sc, out


@pytest.fixture(scope="module", params=["planar", "spatial"])
def free_run(request):
    return _free_run(request.param)


def test_free_run_is_really_free_and_moving(free_run):
    """The scenario is not trivially conserved: thrusters silent, base tumbling, arm moving."""
    robot, sc, out = free_run
    assert all(np.all(o["F"] == 0.0) and np.all(o["M"] == 0.0) for _, o in out)
    assert all(np.all(o["J"] == 0.0) and np.all(o["H"] == 0.0) for _, o in out)
    qd = np.array([o["qd"] for _, o in out])
    assert np.abs(qd).max() > 0.05                               # the arm moves
    A0 = out[0][1]["A"]
    assert max(np.linalg.norm(o["A"] - A0) for _, o in out) > 0.05  # the base turns
    P = out[0][1]["P"]
    assert np.linalg.norm(P) > 100.0 and np.linalg.norm(out[0][1]["L"]) > 100.0


def test_momentum_conserved_thrusters_off(free_run):
    robot, sc, out = free_run
    P0, L0 = out[0][1]["P"], out[0][1]["L"]
    eP = rel_dev([o["P"] for _, o in out], P0, np.linalg.norm(P0))
    eL = rel_dev([o["L"] for _, o in out], L0, np.linalg.norm(L0))
    print(f"{robot}: thrusters off 20 s, max |P - P0|/|P0| = {eP:.2e}, |L - L0|/|L0| = {eL:.2e}")
    assert eP <= 1e-9
    assert eL <= 1e-9


def test_free_run_spatial_drift_is_truncation_error():
    """The spatial angular-momentum drift converges with h (RK4 order) -> it is no leak.

    A physical error (a spurious external force or torque, a wrong inertia in the momentum)
    would not shrink when h is halved. Compared at 10 s: the h = 0.5 ms run of the fixture and
    a run at the paper's h = 1 ms.
    """
    robot, sc, out = _free_run("spatial")
    assert FREE_RUN_H["spatial"] == 5e-4
    t10 = [o for t, o in out if abs(t - 10.0) < 1e-9]
    assert len(t10) == 1
    L0 = out[0][1]["L"]
    drift = {5e-4: np.linalg.norm(t10[0]["L"] - L0) / np.linalg.norm(L0)}
    off = dataclasses.replace(sc.controller, F_max=0.0, M_max=0.0)
    _, p = make_plant("spatial", off, h=1e-3)
    np.testing.assert_array_equal(p.outputs()["L"], L0)
    p.advance(10.0)
    drift[1e-3] = np.linalg.norm(p.outputs()["L"] - L0) / np.linalg.norm(L0)
    print(f"spatial free run 10 s: L drift {drift[1e-3]:.2e} (h = 1 ms), {drift[5e-4]:.2e} (0.5 ms)")
    assert drift[1e-3] < 1e-8
    assert drift[5e-4] < drift[1e-3] / 8.0      # at least third order (RK4: 16)


# ------------------------------------------------------------------------------------------------
# thrusters on: impulse = change of momentum, attitude law, damping
# ------------------------------------------------------------------------------------------------

STATE_TIMES = (1.0, 5.0, 9.0)


@functools.lru_cache(maxsize=None)
def _thrust_run(robot):
    """Controller on (paper scenario), outputs every 0.1 s, states kept at STATE_TIMES."""
    sc, p = make_plant(robot)
    T = 20.0 if robot == "planar" else 10.0
    out, states = record(p, T, 0.1, keep_states=STATE_TIMES)
    return robot, sc, p, out, states


@pytest.fixture(scope="module", params=["planar", "spatial"])
def thrust_run(request):
    return _thrust_run(request.param)


def test_impulse_equals_momentum_change(thrust_run):
    robot, sc, p, out, _ = thrust_run
    P0, L0 = out[0][1]["P"], out[0][1]["L"]
    Lscale = max(np.linalg.norm(o["L"]) for _, o in out)
    eP = max(np.linalg.norm(o["P"] - P0 - o["J"]) for _, o in out) / np.linalg.norm(P0)
    eL = max(np.linalg.norm(o["L"] - L0 - o["H"]) for _, o in out) / Lscale
    print(f"{robot}: thrusters on, max |P - P0 - J|/|P0| = {eP:.2e}, |L - L0 - H|/|L| = {eL:.2e}")
    # the test is not vacuous: the thrusters did change the momentum
    assert np.linalg.norm(out[-1][1]["J"]) > 50.0
    assert np.linalg.norm(out[-1][1]["H"]) > 50.0
    assert eP <= 1e-9
    assert eL <= 1e-9


def test_thrusters_saturate_and_damp_linear_momentum():
    """Planar paper state: |P| >> P_max, so F = -F_max sign(P) per axis and P drops F_max t."""
    sc = scenario("planar")
    _, p = make_plant("planar")
    c = sc.controller
    P0 = p.outputs()["P"]
    assert np.all(np.abs(P0[:2]) > c.P_max + 20.0 * c.F_max)   # stays saturated for 20 s
    expected_F = -np.sign(P0[:2]) * c.F_max
    for _ in range(4):
        p.advance(5.0)
        o = p.outputs()
        assert np.array_equal(o["F"][:2], expected_F)
        assert o["F"][2] == 0.0
        P_expected = P0[:2] + expected_F * p.t          # P decreases by F_max t per axis
        assert np.abs(o["P"][:2] - P_expected).max() <= 1e-9 * np.linalg.norm(P0)
        assert np.all(np.abs(o["P"][:2]) < np.abs(P0[:2]))


def _attitude_reference(c, h, T):
    """theta'' + K_D theta' + K_P theta = 0, theta(0) = 0, theta'(0) = 0.1: the continuous
    solution, and the same law with the commanded acceleration held over each step h (ZOH)."""
    KD, KP = c.K_D, c.K_P
    assert KD**2 < 4 * KP                            # paper gains: under-damped
    s, wd = KD / 2.0, math.sqrt(KP - KD**2 / 4.0)

    def cont(t):
        return 0.1 / wd * np.exp(-s * t) * np.sin(wd * t)

    n = int(round(T / h))
    x, zoh = np.array([0.0, 0.1]), np.empty(n + 1)
    zoh[0] = 0.0
    for k in range(n):
        a = -KD * x[1] - KP * x[0]
        x = np.array([x[0] + h * x[1] + 0.5 * h * h * a, x[1] + h * a])
        zoh[k + 1] = x[0]
    t = np.arange(n + 1) * h
    return cont, float(np.abs(zoh - cont(t)).max())


def test_base_attitude_follows_eq39():
    """theta(t) from base.A against the analytic solution of eq. 39.

    Tolerance: the controller is a 1 kHz digital one (commands held over h = 1 ms), which is
    not the continuous law; the same law with a held base acceleration departs from the
    analytic solution by dev_zoh (2.7e-5 rad, 3e-4 of the 0.09 rad peak). We allow 2 dev_zoh.
    A 1 % error in either gain moves theta by > 1e-4 rad, so the test detects it.
    """
    robot, sc, p, out, _ = _thrust_run("planar")
    assert sc.omega0[2] == 0.1 and sc.v0[:2] == (1.0, 2.0)
    c = sc.controller
    cont, dev_zoh = _attitude_reference(c, sc.h, out[-1][0])
    t = np.array([ti for ti, _ in out])
    theta = np.array([math.atan2(o["A"][1, 0], o["A"][0, 0]) for _, o in out])
    err = np.abs(theta - cont(t)).max()
    print(f"planar attitude: max |theta - eq39| = {err:.2e} rad; ZOH deviation {dev_zoh:.2e} rad; "
          f"peak {theta.max():.4f} rad")
    assert 1e-5 < dev_zoh < 1e-4
    assert err <= 2.0 * dev_zoh
    # sensitivity: the same comparison with K_D 1 % off fails by a wide margin
    cont_wrong, _ = _attitude_reference(dataclasses.replace(c, K_D=1.01 * c.K_D), sc.h, 1.0)
    assert np.abs(theta - cont_wrong(t)).max() > 4.0 * dev_zoh
    # base rate: omega(0) = 0.1, then decays (the attitude is held in the end)
    assert abs(theta[-1]) < 1e-3 and abs(out[-1][1]["omega_B"][2]) < 1e-3


# ------------------------------------------------------------------------------------------------
# Pinocchio vs plain-numpy sums over bodies, at random states
# ------------------------------------------------------------------------------------------------


def random_physical_state(sc, rng):
    """Random base pose/twist and arm state in physical terms (not Pinocchio's)."""
    n = sc.robot.n_joints
    r_S = rng.uniform(-5, 5, 3)
    q_arm = rng.uniform(-math.pi, math.pi, n)
    qd = rng.uniform(-0.5, 0.5, n)
    v_S = rng.uniform(-3, 3, 3)
    omega_B = rng.uniform(-0.4, 0.4, 3)
    if sc.robot.planar:
        r_S[2] = v_S[2] = 0.0
        omega_B[:2] = 0.0
        th = rng.uniform(-math.pi, math.pi)
        A = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0], [0, 0, 1]])
        head_q = [r_S[0], r_S[1], math.cos(th), math.sin(th)]
        vl = A.T @ v_S
        head_v = [vl[0], vl[1], omega_B[2]]
    else:
        rot = Rotation.random(random_state=rng)
        A = rot.as_matrix()
        head_q = list(r_S) + list(rot.as_quat())    # scipy and Pinocchio: (x, y, z, w)
        head_v = list(A.T @ v_S) + list(omega_B)    # free-flyer: base-frame linear velocity
    q = np.concatenate([head_q, q_arm])
    v = np.concatenate([head_v, qd])
    phys = dict(r_S=r_S, A=A, v_S=v_S, omega_B=omega_B, q=q_arm, qd=qd)
    return q, v, phys


def independent_momentum(sc, kin, s):
    """sum m_i v_i and sum A_i I_i A_i^T w_i + m_i r_i x v_i over base, links and target."""
    z = np.zeros(3)
    links, ee = kin.compute(s["r_S"], s["A"], s["v_S"], s["omega_B"], z, z, s["q"], s["qd"],
                            np.zeros(kin.n))
    P, L = kin.momentum(links)
    b, t = sc.robot.base, sc.target
    for body, r_O, A, v_O, w in ((b, s["r_S"], s["A"], s["v_S"], s["A"] @ s["omega_B"]),
                                 (t, ee.r, ee.A, ee.v, ee.w)):
        Pi, Li = body_momentum(body.mass, np.array(body.com), body.inertia_matrix(), r_O, A, v_O, w)
        P, L = P + Pi, L + Li
    return P, L


def body_wrench(m, b, I_c, r_O, A, a_O, w, beta, r_ref):
    """Force and moment about r_ref that give one body its motion (Newton-Euler)."""
    c = A @ b
    a_c = a_O + np.cross(beta, c) + np.cross(w, np.cross(w, c))
    I = A @ I_c @ A.T
    return m * a_c, I @ beta + np.cross(w, I @ w) + np.cross(r_O + c - r_ref, m * a_c)


def independent_wrench(sc, kin, o):
    """sum m_i a_i and sum I_i beta_i + w_i x I_i w_i + m_i (r_i - r_S) x a_i, from the measured
    accelerations."""
    links, ee = kin.compute(o["r_S"], o["A"], o["v_S"], o["omega_B"], o["a_S"], o["alpha_B"],
                            o["q"], o["qd"], o["qdd"])
    F, M = kin.rate_of_momentum(links, o["r_S"])
    b, t = sc.robot.base, sc.target
    A = o["A"]
    for body, args in ((b, (o["r_S"], A, o["a_S"], A @ o["omega_B"], A @ o["alpha_B"])),
                       (t, (ee.r, ee.A, ee.a, ee.w, ee.beta))):
        Fi, Mi = body_wrench(body.mass, np.array(body.com), body.inertia_matrix(), *args, o["r_S"])
        F, M = F + Fi, M + Mi
    return F, M


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_momentum_and_dynamics_match_numpy_sum_at_random_states(robot):
    sc, p = make_plant(robot)
    kin = ArmKinematics(sc.robot)
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(8):
        q, v, s = random_physical_state(sc, rng)
        p.set_state({"t": 0.0, "q": q, "v": v, "J": np.zeros(3), "H": np.zeros(3)})
        o = p.outputs()
        # the plant reports the state the test built (conventions: A body -> inertial,
        # v_S inertial, omega in the base frame)
        for k in ("r_S", "A", "v_S", "omega_B", "q", "qd"):
            np.testing.assert_allclose(o[k], s[k], rtol=0, atol=1e-12, err_msg=k)
        P, L = independent_momentum(sc, kin, s)
        assert np.linalg.norm(o["P"] - P) <= 1e-9 * np.linalg.norm(P)
        assert np.linalg.norm(o["L"] - L) <= 1e-9 * np.linalg.norm(L)
        # force form: the thrust (at S) and the thruster torque are the rate of momentum of
        # all bodies, with Pinocchio's accelerations (joint torques are internal)
        F, M = independent_wrench(sc, kin, o)
        Fs = max(np.linalg.norm(o["F"]), sc.controller.F_max)
        Ms = max(np.linalg.norm(o["M"]), sc.controller.M_max)
        assert np.linalg.norm(o["F"] - F) <= 1e-9 * Fs, (o["F"], F)
        assert np.linalg.norm(o["M"] - M) <= 1e-9 * Ms, (o["M"], M)
        assert np.abs(o["tau"]).max() > 0.0       # the arm is actuated: torques must cancel


def test_force_form_holds_along_trajectory(thrust_run):
    """sum F = sum m a and the moment about S, at every 0.1 s sample of the controlled run."""
    robot, sc, p, out, _ = thrust_run
    kin = ArmKinematics(sc.robot)
    eF = eM = 0.0
    for _, o in out:
        F, M = independent_wrench(sc, kin, o)
        eF = max(eF, np.linalg.norm(o["F"] - F) / sc.controller.F_max)
        eM = max(eM, np.linalg.norm(o["M"] - M) / sc.controller.M_max)
    print(f"{robot}: max |F - sum m a|/F_max = {eF:.1e}, |M - sum M_S|/M_max = {eM:.1e}")
    assert eF <= 1e-9 and eM <= 1e-9


def test_measured_accelerations_are_velocity_derivatives(thrust_run):
    """base.a, base.alpha, arm.qdd against forward differences of base.v, base.omega, arm.qd.

    At states saved along the trajectory: one RK4 step of eps < h from the same state (the
    plant's advance: one step of the rest, the controls of the state held), forward differences
    at eps, eps/2, eps/4, eps/8 combined by Richardson extrapolation (error O(eps^4)). Plain
    differences are not enough near the spatial wrist singularity, where the held-torque
    dynamics have third derivatives of ~2e4 rad/s^4.
    """
    robot, sc, p, out, states = thrust_run
    assert len(states) == len(STATE_TIMES)

    def velocity(o):
        return np.concatenate([o["v_S"], o["omega_B"], o["qd"]])

    def forward(st, eps, v0):
        p.set_state(st)
        p.advance(eps)
        assert abs(p.t - st["t"] - eps) < 1e-15
        return (velocity(p.outputs()) - v0) / eps

    eps = 4e-4
    assert eps < sc.h
    for st in states:
        p.set_state(st)
        o = p.outputs()
        meas = np.concatenate([o["a_S"], o["alpha_B"], o["qdd"]])
        R = [forward(st, eps / 2 ** i, velocity(o)) for i in range(4)]
        for j in range(1, 4):               # Richardson: D(e) = a + c1 e + c2 e^2 + ...
            R = [(2 ** j * R[i + 1] - R[i]) / (2 ** j - 1) for i in range(len(R) - 1)]
        fd = R[0]
        for name, sl in (("a_S", slice(0, 3)), ("alpha_B", slice(3, 6)), ("qdd", slice(6, None))):
            scale = max(np.abs(meas[sl]).max(), 1e-3)
            assert np.abs(fd[sl] - meas[sl]).max() <= 1e-8 * scale, (robot, st["t"], name,
                                                                     fd[sl], meas[sl])
        assert np.abs(o["qdd"]).max() > 1e-4        # non-trivial accelerations


def test_rk4_step_is_fifth_order_locally():
    """Classic RK4: one step of dt from a state (controls held, thrusters off, so P and L of
    the held-control dynamics are exact invariants) changes P and L by the local truncation
    error, O(dt^5): halving dt cuts it 32x (the global error over a fixed span then goes as
    h^4, 16x per halving). Spatial free run, states at 4 s and 9 s, dt = 40, 20, 10 ms."""
    sc = scenario("spatial")
    off = dataclasses.replace(sc.controller, F_max=0.0, M_max=0.0)
    p = Plant(sc.robot, sc.robot.base, sc.target, off, sc.v0, sc.omega0, 1e-3)
    one = Plant(sc.robot, sc.robot.base, sc.target, off, sc.v0, sc.omega0, 0.1)  # 1 step < h
    for T in (4.0, 9.0):
        p.advance(T - p.t)
        st = p.get_state()
        one.set_state(st)
        o0 = one.outputs()
        err = []
        for dt in (0.04, 0.02, 0.01):
            one.set_state(st)
            one.advance(dt)
            o = one.outputs()
            err.append([np.linalg.norm(o[k] - o0[k]) / np.linalg.norm(o0[k]) for k in ("P", "L")])
        err = np.array(err)
        ratio = err[:-1] / err[1:]
        print(f"t = {T}: relative P, L change {err.tolist()}, ratios per halving {ratio.tolist()}")
        assert err.min() > 1e-14                   # far above round-off (1e-16)
        assert np.all((ratio > 24.0) & (ratio < 42.0)), ratio


# ------------------------------------------------------------------------------------------------
# communication steps that are not multiples of h
# ------------------------------------------------------------------------------------------------


def test_partial_last_step():
    """advance(0.1005) = 100 RK4 steps of h + one of 0.0005 (advance(0.1) then advance(0.0005));
    advance(0.3) = exactly 300 of h (300 calls of advance(h)). To round-off (1e-11 relative):
    the joint sines are evaluated afresh at the start of each call and rotated in between."""
    _, a = make_plant("planar")
    _, b = make_plant("planar")
    a.advance(0.1005)
    b.advance(0.1)
    mid = b.get_state()
    b.advance(0.0005)
    assert abs(a.t - 0.1005) < 1e-15
    for x, y in ((a.q, b.q), (a.v, b.v), (a.H, b.H), (a.J, b.J)):
        np.testing.assert_allclose(x, y, rtol=1e-11, atol=1e-14)
    # the short step is really a step of 0.5 ms: not 0 and not a full h
    assert not np.allclose(a.v, mid["v"], rtol=1e-12, atol=0)
    b.set_state(mid)
    b.advance(1e-3)
    assert not np.allclose(a.v, b.v, rtol=1e-12, atol=0)
    # whole multiples: no spurious extra step
    _, c = make_plant("spatial")
    _, d = make_plant("spatial")
    c.advance(0.3)
    for _ in range(300):
        d.advance(1e-3)
    assert abs(c.t - 0.3) < 1e-12
    for x, y in ((c.q, d.q), (c.v, d.v), (c.H, d.H), (c.J, d.J)):
        np.testing.assert_allclose(x, y, rtol=1e-11, atol=1e-14)


