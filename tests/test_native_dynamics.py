"""The native rigid-body dynamics (native/src/dynamics.c) against Pinocchio: forward dynamics
(ABA), joint-space inertia (CRBA), non-linear effects (RNEA) and momentum at random states, for
the planar and spatial robots and the shipped 7-joint servicer URDF (each with a grasped
target, through the robot record and the C reader; the Pinocchio models of the test oracle
tests/oracles/pinocchio_model.py), and random 7- and 8-joint chains (joints about x, y, z, -z and
random axes); the ABA against M^-1 (tau - nle) of the C CRBA/RNEA; the physical-state interface
against Pinocchio's classical base acceleration; momentum conservation (and balance under
thrust) along an RK4 integration."""
from __future__ import annotations

import ctypes
import importlib.util
import os
import zlib
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from oracles.pinocchio_model import build_model, random_chain, random_state
from spacerobot.core import robot_record as rr
from spacerobot.robots import ROBOTS, URDF_DIR, RigidBody, get_robot

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-12
TARGET = RigidBody(120.0, (0.05, 0.02, -0.03), (9.0, 7.0, 5.0, 0.3, -0.2, 0.1))
_D = ctypes.POINTER(ctypes.c_double)
_V = ctypes.c_void_p


# -- the library --------------------------------------------------------------------------------

def _core_library(tmp_dir: Path) -> ctypes.CDLL:
    """$SPACEROBOT_CORE_LIB, else the installed library if it has the dynamics, else a fresh
    build of the plant's sources and equations.c (native/build.py, warnings are errors)."""
    from spacerobot import core
    if os.environ.get("SPACEROBOT_CORE_LIB"):
        return core.load_library()
    try:
        lib = core.load_library()
        if hasattr(lib, "sr_dyn_aba") and hasattr(lib, "sr_robot_parse"):
            return lib
    except (core.CoreUnavailable, OSError):
        pass
    spec = importlib.util.spec_from_file_location("_sr_native_build", ROOT / "native" / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    path = build.build_library(tmp_dir, [*build.MODEL_SOURCES["plant"], "equations.c"], strict=True)
    return core.load_library(path)


def bind(L: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the sr_dyn_* signatures on the library."""
    L.sr_dyn_model_size.restype = ctypes.c_size_t
    L.sr_dyn_data_size.restype = ctypes.c_size_t
    L.sr_dyn_model_init.argtypes = [_V, ctypes.POINTER(rr.SrRobot), ctypes.POINTER(rr.SrBody)]
    L.sr_dyn_set_base_spatial.argtypes = [_V, ctypes.c_double, _D, _D]
    L.sr_dyn_set_base.argtypes = [_V, ctypes.POINTER(rr.SrBody)]
    L.sr_dyn_aba.argtypes = [_V, _V, _D, _D, _D, _D]
    L.sr_dyn_terms.argtypes = [_V, _V, _D, _D, _D, _D, _D, _D]
    L.sr_dyn_generalised.argtypes = [_V, _D, _D, _D, _D, _D, _D, _D, _D]
    L.sr_dyn_generalised_force.argtypes = [_V, _D, _D, _D, _D, _D]
    L.sr_dyn_forward.argtypes = [_V, _V] + [_D] * 11
    L.sr_dyn_mass_bias.argtypes = [_V, _V] + [_D] * 7
    L.sr_dyn_momentum.argtypes = [_V, _V] + [_D] * 9
    rr._bind(L)
    return L


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return bind(_core_library(tmp_path_factory.mktemp("dynlib")))


def P(a):
    """``double *`` of a float64 array (None for None)."""
    if a is None:
        return None
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data_as(_D)


class Dyn:
    """A C model + work space of one robot, with NumPy-facing calls."""

    def __init__(self, L, robot: rr.SrRobot, target: rr.SrBody | None):
        self.L = L
        self.model = ctypes.create_string_buffer(L.sr_dyn_model_size())
        self.data = ctypes.create_string_buffer(L.sr_dyn_data_size())
        st = L.sr_dyn_model_init(self.model, ctypes.byref(robot),
                                 ctypes.byref(target) if target is not None else None)
        assert st == 0
        self.n, self.planar = robot.n, bool(robot.planar)
        self.nv = self.n + (3 if self.planar else 6)
        self.nq = self.n + (4 if self.planar else 7)

    def aba(self, q, v, tau):
        ddq = np.full(self.nv, np.nan)
        assert self.L.sr_dyn_aba(self.model, self.data, P(q), P(v), P(tau), P(ddq)) == 0
        return ddq

    def terms(self, q, v):
        M, nle, hg, com = np.empty((self.nv, self.nv)), np.empty(self.nv), np.empty(6), np.empty(3)
        assert self.L.sr_dyn_terms(self.model, self.data, P(q), P(v), P(M), P(nle), P(hg),
                                   P(com)) == 0
        return M, nle, hg, com

    def generalised(self, r, A, vS, w, qa, qd):
        q, v = np.empty(self.nq), np.empty(self.nv)
        assert self.L.sr_dyn_generalised(self.model, *map(P, (r, A.ravel().copy(), vS, w, qa, qd,
                                                              q, v))) == 0
        return q, v

    def gen_force(self, A, F, M, tau):
        g = np.empty(self.nv)
        assert self.L.sr_dyn_generalised_force(self.model, *map(P, (A.ravel().copy(), F, M,
                                                                    tau, g))) == 0
        return g

    def forward(self, A, vS, w, qa, qd, F, M, tau):
        aS, al, qdd = np.empty(3), np.empty(3), np.empty(self.n)
        assert self.L.sr_dyn_forward(self.model, self.data, *map(P, (
            A.ravel().copy(), vS, w, qa, qd, F, M, tau, aS, al, qdd))) == 0
        return aS, al, qdd

    def mass_bias(self, A, vS, w, qa, qd):
        M, h = np.empty((self.nv, self.nv)), np.empty(self.nv)
        assert self.L.sr_dyn_mass_bias(self.model, self.data, *map(P, (
            A.ravel().copy(), vS, w, qa, qd, M, h))) == 0
        return M, h

    def momentum(self, r, A, vS, w, qa, qd):
        Pm, Lm, com = np.empty(3), np.empty(3), np.empty(3)
        assert self.L.sr_dyn_momentum(self.model, self.data, *map(P, (
            r, A.ravel().copy(), vS, w, qa, qd, Pm, Lm, com))) == 0
        return Pm, Lm, com


# -- the robots: each as an sr_robot (+ target) and as its Pinocchio model --------------------

def _sr_body(b) -> rr.SrBody:
    out = rr.SrBody()
    out.m = float(b.mass)
    out.com[:] = [float(x) for x in np.asarray(b.com if hasattr(b, "com") else b.lever)]
    out.I[:] = [float(x) for x in np.asarray(b.inertia_matrix() if hasattr(b, "inertia_matrix")
                                             else b.inertia).ravel()]
    return out


def _sr_robot_of_pinocchio(model: pin.Model) -> rr.SrRobot:
    """The sr_robot of a Pinocchio free-flyer + revolute chain (tests' random chains): joint
    placements, axes and body inertias (in the joint frames) copied; no end effector offset."""
    r = rr.SrRobot()
    r.name = b"chain"
    r.planar = 0
    r.n = model.njoints - 2
    unit = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0),
            "JointModelRZ": (0.0, 0.0, 1.0)}
    r.base = _sr_body(model.inertias[1])
    for k in range(r.n):
        j = k + 2
        jm = model.joints[j]
        ax = unit.get(jm.shortname())
        if ax is None:
            ax = np.asarray(jm.extract().axis, float)
        M = model.jointPlacements[j]
        r.xyz[k][:] = [float(x) for x in M.translation]
        r.R[k][:] = [float(x) for x in M.rotation.ravel()]
        r.axis[k][:] = [float(x) for x in ax]
        r.link[k] = _sr_body(model.inertias[j])
        r.joint[k].value = f"j{k}".encode()
    r.ee_R[:] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    return r


def _cases(L):
    out = {}
    for name, robot in [*ROBOTS.items(),
                        ("servicer7", get_robot(str(URDF_DIR / "servicer7.urdf")))]:
        out[name] = (rr.c_robot(robot, L), _sr_body(TARGET),
                     build_model(robot, target=TARGET).model)
    for name, rng, n, kinds in [("chain7", 7, 7, "uuz"), ("chain_xyzm", 8, 8, "xyzmu")]:
        model = random_chain(np.random.default_rng(rng), n=n, kinds=kinds)
        out[name] = (_sr_robot_of_pinocchio(model), None, model)
    return out


NAMES = ["planar", "spatial", "servicer7", "chain7", "chain_xyzm"]


@pytest.fixture(scope="module")
def cases(lib):
    return {name: (Dyn(lib, r, t), model) for name, (r, t, model) in _cases(lib).items()}


def _rng(name: str) -> np.random.Generator:
    """A generator of reproducible random states: NumPy's and Pinocchio's (its
    randomConfiguration) seeded from the test's name."""
    seed = zlib.crc32(name.encode())
    pin.seed(seed)
    return np.random.default_rng(seed)


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(1.0, np.max(np.abs(b))))


def _physical(model, q, v):
    """(r_S, A, v_S, omega_B, q_arm, qd) of Pinocchio's (q, v)."""
    planar = model.joints[1].shortname() == "JointModelPlanar"
    n = model.nv - (3 if planar else 6)
    if planar:
        c, s = q[2], q[3]
        A = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        r = np.array([q[0], q[1], 0.0])
        vl = np.array([v[0], v[1], 0.0])
        w = np.array([0.0, 0.0, v[2]])
    else:
        A = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix()
        r, vl, w = q[:3].copy(), v[:3].copy(), v[3:6].copy()
    return r, A, A @ vl, w, q[-n:].copy(), v[-n:].copy()


# -- generalised coordinates against Pinocchio ------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_aba_crba_rnea_momentum_equal_pinocchio(cases, name):
    dyn, model = cases[name]
    data = model.createData()
    rng = _rng(name)
    worst = dict(aba=0.0, M=0.0, nle=0.0, hg=0.0, com=0.0, inv=0.0)
    for _ in range(20):
        q, v, tau = random_state(model, rng)
        ddq = dyn.aba(q, v, tau)
        ref = pin.aba(model, data, q, v, tau)
        worst["aba"] = max(worst["aba"], _rel(ddq, ref))
        M, nle, hg, com = dyn.terms(q, v)
        pin.computeAllTerms(model, data, q, v)
        Mref = np.triu(data.M) + np.triu(data.M, 1).T
        worst["M"] = max(worst["M"], float(np.max(np.abs(M - Mref)) / np.max(np.abs(Mref))))
        worst["nle"] = max(worst["nle"], _rel(nle, data.nle))
        worst["hg"] = max(worst["hg"], _rel(hg, data.hg.vector))
        worst["com"] = max(worst["com"], _rel(com, data.com[0]))
        # the ABA solves M ddq = tau - nle (the C CRBA/RNEA; LAPACK's solve)
        worst["inv"] = max(worst["inv"], _rel(ddq, np.linalg.solve(M, tau - nle)))
    print(name, {k: f"{x:.1e}" for k, x in worst.items()})
    for k in ("aba", "M", "nle", "hg", "com"):
        assert worst[k] <= TOL, (k, worst[k])
    assert worst["inv"] <= 1e-10           # through the conditioning of M


@pytest.mark.parametrize("name", NAMES)
def test_physical_state_interface(cases, name):
    """sr_dyn_forward / mass_bias / momentum / generalised(_force) of the physical state:
    accelerations equal Pinocchio's classical acceleration of the base frame, momentum about
    the inertial origin equals Pinocchio's centroidal one moved there."""
    dyn, model = cases[name]
    data = model.createData()
    rng = _rng(name + "phys")
    for _ in range(10):
        q, v, _ = random_state(model, rng)
        r, A, vS, w, qa, qd = _physical(model, q, v)
        F, Mt, tau = rng.normal(scale=50.0, size=3), rng.normal(scale=50.0, size=3), \
            rng.normal(scale=20.0, size=dyn.n)
        q2, v2 = dyn.generalised(r, A, vS, w, qa, qd)
        if dyn.planar:
            assert np.max(np.abs(q2 - q)) <= 1e-15 and np.max(np.abs(v2 - v)) <= 1e-13
        else:
            # the quaternion up to its sign
            sgn = np.sign(q[6]) if q[6] != 0 else 1.0
            qq = q.copy()
            qq[3:7] *= sgn
            assert np.max(np.abs(q2 - qq)) <= 1e-14 and np.max(np.abs(v2 - v)) <= 1e-13
        gen = dyn.gen_force(A, F, Mt, tau)
        if dyn.planar:
            ref = np.concatenate([(A.T @ F)[:2], [Mt[2]], tau])
        else:
            ref = np.concatenate([A.T @ F, A.T @ Mt, tau])
        assert np.max(np.abs(gen - ref)) <= 1e-13 * max(1.0, np.max(np.abs(ref)))
        # forward dynamics: Pinocchio's ABA, then the classical acceleration of joint 1's origin
        ddq = pin.aba(model, data, q, v, gen)
        pin.forwardKinematics(model, data, q, v, ddq)
        aref = pin.getClassicalAcceleration(model, data, 1, pin.LOCAL_WORLD_ALIGNED).linear
        alref = pin.getClassicalAcceleration(model, data, 1, pin.LOCAL).angular
        aS, al, qdd = dyn.forward(A, vS, w, qa, qd, F, Mt, tau)
        scale = max(1.0, np.max(np.abs(ddq)), np.max(np.abs(aref)))
        assert np.max(np.abs(aS - aref)) <= TOL * scale
        assert np.max(np.abs(al - alref)) <= TOL * scale
        assert np.max(np.abs(qdd - ddq[-dyn.n:])) <= TOL * scale
        M, h = dyn.mass_bias(A, vS, w, qa, qd)
        pin.computeAllTerms(model, data, q, v)
        Mref = np.triu(data.M) + np.triu(data.M, 1).T
        assert np.max(np.abs(M - Mref)) <= TOL * np.max(np.abs(Mref))
        assert _rel(h, data.nle) <= TOL
        Pm, Lm, com = dyn.momentum(r, A, vS, w, qa, qd)
        Pref, Lc = data.hg.linear, data.hg.angular
        cref = data.com[0]
        Lref = Lc + np.cross(cref, Pref)      # about the inertial origin
        assert _rel(Pm, Pref) <= TOL and _rel(com, cref) <= TOL
        assert np.max(np.abs(Lm - Lref)) <= TOL * max(1.0, np.max(np.abs(Lc)),
                                                      np.max(np.abs(np.cross(cref, Pref))))


# -- conservation laws (independent of Pinocchio) -------------------------------------------

def _rk4_momentum(dyn, r, A, vS, w, qa, qd, F, Mt, tau, h, steps):
    """RK4 of the physical state [r_S, A, v_S, omega_B, q, qd] and H = int (M + r_S x F) dt
    under constant F, M_S (inertial) and tau; returns (P, L) at the start and the end and the
    integrated H."""
    n = dyn.n

    def pack(r, A, vS, w, qa, qd, H):
        return np.concatenate([r, A.ravel(), vS, w, qa, qd, H])

    def unpack(x):
        return (x[:3], x[3:12].reshape(3, 3), x[12:15], x[15:18], x[18:18 + n],
                x[18 + n:18 + 2 * n], x[18 + 2 * n:])

    def rate(x):
        r, A, vS, w, qa, qd, H = unpack(x)
        aS, al, qdd = dyn.forward(A, vS, w, qa, qd, F, Mt, tau)
        W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        return pack(vS, A @ W, aS, al, qd, qdd, Mt + np.cross(r, F))

    x = pack(r, A, vS, w, qa, qd, np.zeros(3))
    P0, L0, _ = dyn.momentum(*unpack(x)[:6])
    for _ in range(steps):
        k1 = rate(x)
        k2 = rate(x + 0.5 * h * k1)
        k3 = rate(x + 0.5 * h * k2)
        k4 = rate(x + h * k3)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    P1, L1, _ = dyn.momentum(*unpack(x)[:6])
    return P0, L0, P1, L1, unpack(x)[6]


@pytest.mark.parametrize("name", ["planar", "spatial", "servicer7", "chain_xyzm"])
def test_momentum_conserved_and_balanced_along_rk4(cases, name):
    dyn, model = cases[name]
    rng = _rng(name + "rk4")
    q, v, _ = random_state(model, rng)
    v *= 0.3
    r, A, vS, w, qa, qd = _physical(model, q, v)
    tau = rng.normal(scale=5.0, size=dyn.n)         # internal: momentum is conserved
    zero = np.zeros(3)
    P0, L0, P1, L1, _ = _rk4_momentum(dyn, r, A, vS, w, qa, qd, zero, zero, tau, 2e-3, 100)
    # planar: the plane's constraint (force along z, moments about x, y) changes P_z, L_x, L_y
    keep = (slice(0, 2), slice(2, 3)) if dyn.planar else (slice(0, 3), slice(0, 3))
    scale = max(np.max(np.abs(P0)), np.max(np.abs(L0)), 1.0)
    drift = max(np.max(np.abs((P1 - P0)[keep[0]])), np.max(np.abs((L1 - L0)[keep[1]]))) / scale
    print(name, f"momentum drift over 0.2 s free-floating: {drift:.1e}")
    assert drift <= 1e-10
    # with thrust: dP/dt = F, dL/dt = M_S + r_S x F (the plant's J, H balance)
    F = rng.normal(scale=20.0, size=3)
    Mt = rng.normal(scale=20.0, size=3)
    if dyn.planar:
        F[2], Mt[:2] = 0.0, 0.0
    T = 0.2                             # RK4's error here: O(h^4), 1e-12 relative or less
    P0, L0, P1, L1, H = _rk4_momentum(dyn, r, A, vS, w, qa, qd, F, Mt, tau, 1e-3, 200)
    Perr = np.max(np.abs((P1 - (P0 + F * T))[keep[0]])) / max(1.0, np.max(np.abs(P1)))
    Lerr = np.max(np.abs((L1 - (L0 + H))[keep[1]])) / max(1.0, np.max(np.abs(L1)),
                                                          np.max(np.abs(H)))
    print(name, f"momentum balance error over 0.2 s under thrust (relative): P {Perr:.1e}, "
          f"L {Lerr:.1e}")
    assert Perr <= 1e-11 and Lerr <= 1e-11


# -- bad input ---------------------------------------------------------------------------------

def test_bad_input_is_refused(lib, cases):
    dyn, model = cases["spatial"]
    nv = dyn.nv
    q, v, tau, ddq = np.zeros(dyn.nq), np.zeros(nv), np.zeros(nv), np.zeros(nv)
    q[6] = 1.0
    assert lib.sr_dyn_aba(None, dyn.data, P(q), P(v), P(tau), P(ddq)) == 1
    assert lib.sr_dyn_aba(dyn.model, None, P(q), P(v), P(tau), P(ddq)) == 1
    assert lib.sr_dyn_aba(dyn.model, dyn.data, P(q), None, P(tau), P(ddq)) == 1
    assert lib.sr_dyn_terms(dyn.model, dyn.data, P(q), P(v), None, None, None, None) == 0
    # a model never initialised (zeroed) is refused
    blank = ctypes.create_string_buffer(lib.sr_dyn_model_size())
    assert lib.sr_dyn_aba(blank, dyn.data, P(q), P(v), P(tau), P(ddq)) == 1
    # invalid robots / targets
    r = rr.c_robot(ROBOTS["spatial"], lib)
    m = ctypes.create_string_buffer(lib.sr_dyn_model_size())
    for field, value in [("n", 0), ("n", 13), ("planar", 2)]:
        bad = rr.SrRobot.from_buffer_copy(r)
        setattr(bad, field, value)
        assert lib.sr_dyn_model_init(m, ctypes.byref(bad), None) == 1
    bad = rr.SrRobot.from_buffer_copy(r)
    bad.link[0].m = float("nan")
    assert lib.sr_dyn_model_init(m, ctypes.byref(bad), None) == 1
    bad = rr.SrRobot.from_buffer_copy(r)
    bad.axis[1][:] = [0.0, 0.0, 0.0]
    assert lib.sr_dyn_model_init(m, ctypes.byref(bad), None) == 1
    t = _sr_body(TARGET)
    t.m = -1.0
    assert lib.sr_dyn_model_init(m, ctypes.byref(r), ctypes.byref(t)) == 1
    assert lib.sr_dyn_model_init(None, ctypes.byref(r), None) == 1
    # a base without mass is refused; the model is left as it was
    assert lib.sr_dyn_model_init(m, ctypes.byref(r), None) == 0
    assert lib.sr_dyn_set_base_spatial(m, 0.0, P(np.zeros(3)), P(np.zeros(9))) == 1
    assert lib.sr_dyn_aba(m, dyn.data, P(q), P(v), P(tau), P(ddq)) == 0
    # a base inertia that is not positive definite: SR_DYN_EPD, never a crash
    assert lib.sr_dyn_set_base_spatial(m, 1.0, P(np.zeros(3)), P(-np.eye(3).ravel())) == 0
    assert lib.sr_dyn_aba(m, dyn.data, P(q), P(v), P(tau), P(ddq)) == 2


def test_set_base_equals_a_model_with_that_base(lib, cases):
    """sr_dyn_set_base(_spatial): the model of a robot whose base is the one set (the plant's
    propellant: dry base + propellant sphere, spatial inertias added)."""
    robot = ROBOTS["spatial"]
    r = rr.c_robot(robot, lib)
    tgt = _sr_body(TARGET)
    new_base = RigidBody(650.0, (0.02, -0.01, 0.03), (410.0, 380.0, 300.0, 5.0, -3.0, 2.0))
    r2 = rr.SrRobot.from_buffer_copy(r)
    r2.base = _sr_body(new_base)
    ref = Dyn(lib, r2, tgt)
    dyn = Dyn(lib, r, tgt)
    b = _sr_body(new_base)
    assert lib.sr_dyn_set_base(dyn.model, ctypes.byref(b)) == 0
    dyn2 = Dyn(lib, r, tgt)
    c = np.array(new_base.com)
    Ic = new_base.inertia_matrix()
    I_S = Ic + new_base.mass * (c @ c * np.eye(3) - np.outer(c, c))
    assert lib.sr_dyn_set_base_spatial(dyn2.model, new_base.mass, P(new_base.mass * c),
                                       P(np.ascontiguousarray(I_S))) == 0
    model = build_model(robot, base=new_base, target=TARGET).model
    data = model.createData()
    rng = _rng("set_base")
    for _ in range(5):
        q, v, tau = random_state(model, rng)
        want = pin.aba(model, data, q, v, tau)
        for d in (ref, dyn, dyn2):
            assert _rel(d.aba(q, v, tau), want) <= TOL


@pytest.mark.parametrize("cc, flags", [("gcc", ["-fPIC"]), ("x86_64-w64-mingw32-gcc", [])])
def test_compiles_warning_free(tmp_path, cc, flags):
    """dynamics.c is C99 without a warning for gcc (linux64) and mingw-w64 (win64)."""
    import shutil
    import subprocess
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed")
    src = ROOT / "native" / "src"
    r = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", *flags,
                        "-I", str(src), "-c", str(src / "dynamics.c"), "-o",
                        str(tmp_path / "dynamics.o")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
