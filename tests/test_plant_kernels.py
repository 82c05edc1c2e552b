"""The plant's compiled kernels against independent NumPy / Pinocchio computations, and the
persistent kernel cache (spacerobot.jit)."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from spacerobot import jit
from spacerobot.plant import Plant, kernels, rigid_body
from spacerobot.robots import scenario

ROOT = Path(__file__).resolve().parents[1]


# -- small linear algebra ------------------------------------------------------------------------

@pytest.mark.parametrize("k", [1, 2, 3, 6])
def test_jacobi_eigh_matches_lapack(k):
    rng = np.random.default_rng(k)
    cases = []
    for _ in range(20):
        B = rng.normal(size=(k, k))
        cases.append(B + B.T)                                   # indefinite
        cases.append(B @ B.T)                                   # semi-definite
    u = rng.normal(size=k)
    cases.append(np.outer(u, u) + 1e-9 * np.eye(k))             # nearly rank one
    cases.append(np.diag(np.arange(k, 0, -1.0)))                # already diagonal, unsorted
    for S in cases:
        lam, U = np.empty(k), np.empty((k, k))
        kernels._jacobi_eigh(S, lam, U)
        scale = np.abs(S).max()
        assert np.all(np.diff(lam) >= 0.0)
        np.testing.assert_allclose(lam, np.linalg.eigvalsh(S), atol=1e-12 * scale)
        np.testing.assert_allclose(U @ np.diag(lam) @ U.T, S, atol=1e-12 * scale)
        np.testing.assert_allclose(U.T @ U, np.eye(k), atol=1e-12)


def test_sym3_extreme_eigenvalues():
    rng = np.random.default_rng(3)
    for _ in range(200):
        B = rng.normal(size=(3, 3))
        S = B + B.T
        lo, hi = kernels._sym3_eigenvalues(S[0, 0], S[0, 1], S[0, 2], S[1, 1], S[1, 2], S[2, 2])
        ref = np.linalg.eigvalsh(S)
        assert lo == pytest.approx(ref[0], abs=1e-12) and hi == pytest.approx(ref[2], abs=1e-12)


def test_cholesky_solve_and_failure():
    rng = np.random.default_rng(4)
    B = rng.normal(size=(6, 6))
    S = B @ B.T + 6 * np.eye(6)
    L = np.empty((6, 6))
    assert rigid_body.cholesky(S, L)
    X = rng.normal(size=(6, 3))
    Y = X.copy()
    rigid_body.cho_solve(L, Y)
    np.testing.assert_allclose(Y, np.linalg.solve(S, X), rtol=1e-12, atol=1e-12)
    assert not rigid_body.cholesky(-S, L)                          # not positive definite


# -- the controllers, against the law written out with NumPy and Pinocchio -----------------------

def _bounded(x, K, x_max, u_max):
    x = np.asarray(x, float)
    inside = np.clip(K * x, -u_max, u_max)
    return np.where(np.abs(x) >= x_max, np.sign(K * x) * u_max, inside)


def reference_control(planar, q, v, M, nle, hg, c, q_home, refs=None):
    """Eqs. 39-41 as documented in spacerobot/plant/kernels.py, by LAPACK and Pinocchio.

    ``refs``: optional excitation references ``(e_r, e_r', e_r'', q_r, q_r', q_r'')``."""
    nv = len(v)
    nb = 3 if planar else 6
    rot = slice(2, 3) if planar else slice(3, 6)
    F = _bounded(hg[:3], c.K_F, c.P_max, c.F_max)
    Mt = _bounded(hg[3:], c.K_M, c.L_max, c.M_max)
    if planar:
        th = np.arctan2(q[3], q[2])
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        f_b = np.concatenate([R.T @ F[:2], [Mt[2]]])
        e = np.array([th])
    else:
        A = pin.Quaternion(q[3:7] / np.linalg.norm(q[3:7])).matrix()
        f_b = np.concatenate([A.T @ F, A.T @ Mt])
        e = pin.log3(A)
    Mbb, Mbm, Mmm = M[:nb, :nb], M[:nb, nb:], M[nb:, nb:]
    X = np.linalg.solve(Mbb, Mbm)
    y0 = np.linalg.solve(Mbb, f_b - nle[:nb])
    G = X[rot]
    WiGt = np.linalg.solve(Mmm, G.T)
    lam, U = np.linalg.eigh(G @ WiGt)
    lmax = max(lam[-1], 1e-300)
    r = np.clip(lam / lmax, 0.0, None)
    damp = np.where(r < kernels.DLS_RATIO, kernels.DLS_RATIO * lmax * (1 - r / kernels.DLS_RATIO) ** 2,
                    0.0)
    Gp = WiGt @ U @ np.diag(1.0 / (lam + damp)) @ U.T
    er, der, dder, qr, dqr, ddqr = refs if refs is not None else (0.0,) * 6
    post = ddqr - c.K_Pn * (q[-(nv - nb):] - q_home - qr) - c.K_Dn * (v[nb:] - dqr)
    alpha_des = dder - c.K_D * (v[rot] - der) - c.K_P * (e - er)
    qdd = Gp @ (y0[rot] - alpha_des - G @ post) + post
    peak = np.abs(qdd).max()
    if peak > c.qdd_max:
        qdd *= c.qdd_max / peak
    acc = np.concatenate([y0 - X @ qdd, qdd])
    tau = M[nb:] @ acc + nle[nb:]
    return np.concatenate([F, Mt]), np.concatenate([f_b, tau]), acc


#: excitation off: level 0 and no ramp under way (the table is then never read)
NO_RAMP, NO_TAB = np.array([0.0, 0.0, 0.0, 1.0]), np.zeros((9, 5))


def _run_kernel(planar, q, v, M, nle, hg, c, q_home, t=0.0, ramp=NO_RAMP, tab=NO_TAB,
                work_nv=None):
    """The control kernel; ``work_nv``: its work arrays made for another number of velocities
    (their references' sines then do not fit ``tab``)."""
    par = np.array([getattr(c, k) for k in kernels.PARAMS], float)
    nv = len(v)
    gen, acc, FM = np.zeros(nv), np.zeros(nv), np.zeros(6)
    cw = kernels.control_work(planar, nv)
    if work_nv is not None:
        cw = cw[:8] + kernels.control_work(planar, work_nv)[8:]
    err = kernels.control(planar, q, v, M, nle, hg, par, np.asarray(q_home, float), t, ramp, tab,
                          gen, acc, FM, cw)
    assert err == 0
    return FM, gen, acc


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_control_kernel_matches_reference_along_a_run(robot):
    sc = scenario(robot)
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
    model, data = plant.pm.model, plant.pm.model.createData()
    saturated = 0
    for _ in range(40):
        plant.advance(0.25)
        q, v = plant.q.copy(), plant.v.copy()
        M = pin.crba(model, data, q).copy()
        nle = pin.nonLinearEffects(model, data, q, v).copy()
        hg = pin.computeCentroidalMomentum(model, data, q, v).vector.copy()
        FM, gen, acc = _run_kernel(plant.pm.planar, q, v, M, nle, hg, sc.controller, plant.q_home)
        FM_r, gen_r, acc_r = reference_control(plant.pm.planar, q, v, M, nle, hg, sc.controller,
                                               plant.q_home)
        np.testing.assert_allclose(FM, FM_r, rtol=0, atol=1e-12 * max(1.0, np.abs(FM_r).max()))
        np.testing.assert_allclose(gen, gen_r, rtol=0, atol=1e-8 * np.abs(gen_r).max())
        np.testing.assert_allclose(acc, acc_r, rtol=0, atol=1e-8 * np.abs(acc_r).max())
        np.testing.assert_allclose(M @ acc + nle, gen, atol=1e-9 * np.abs(gen).max())
        saturated += np.abs(acc[plant.pm.nb:]).max() >= sc.controller.qdd_max * (1 - 1e-12)
    if robot == "spatial":
        assert saturated > 0          # the bounded branch is exercised too


def _numpy_references(t, ramp, tab, r):
    """Excitation references written out (robots.Excitation, kernels.ramp_level): level
    s = s0 + (u - s0) p(x), p = 10 x^3 - 15 x^4 + 6 x^5, x = (t - t0)/T, times
    f = a/2 (sin(w1 t + p1) + sin(w2 t + p2))."""
    s0, u, t0, T = ramp
    x = min(max((t - t0) / T, 0.0), 1.0)
    s = s0 + (u - s0) * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)
    ds = (u - s0) * (30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4) / T
    dds = (u - s0) * (60 * x - 180 * x ** 2 + 120 * x ** 3) / T ** 2
    a, w1, p1, w2, p2 = tab.T
    f = a / 2 * (np.sin(w1 * t + p1) + np.sin(w2 * t + p2))
    df = a / 2 * (w1 * np.cos(w1 * t + p1) + w2 * np.cos(w2 * t + p2))
    ddf = -a / 2 * (w1 ** 2 * np.sin(w1 * t + p1) + w2 ** 2 * np.sin(w2 * t + p2))
    x, dx, ddx = s * f, ds * f + s * df, dds * f + 2 * ds * df + s * ddf
    return x[:r], dx[:r], ddx[:r], x[r:], dx[r:], ddx[r:]


def test_rotated_sines_of_the_references_stay_at_round_off():
    """rotate_trig stepped over the TRIG_ANCHOR - 1 steps between fresh evaluations (and far
    beyond) against numpy's sin and cos of every phase at the same times: within a few units
    in the last place."""
    sc = scenario("spatial")
    tab = sc.excitation.channels(3, sc.robot.n_joints)
    m, h, t0 = len(tab), sc.h, 7.3
    trig, rot = np.empty((m + 1, 4)), np.empty((m, 4))
    kernels.fill_trig(tab, t0, trig)
    w1, w2 = tab[:, 1], tab[:, 3]
    rot[:] = np.column_stack([np.cos(w1 * h), np.sin(w1 * h), np.cos(w2 * h), np.sin(w2 * h)])
    worst = {}
    for k in range(1, 400):
        t = t0 + k * h
        kernels.rotate_trig(rot, trig, t)
        assert trig[m, 0] == t
        a1, a2 = tab[:, 1] * t0 + tab[:, 2] + tab[:, 1] * (k * h), \
            tab[:, 3] * t0 + tab[:, 4] + tab[:, 3] * (k * h)
        want = np.column_stack([np.sin(a1), np.cos(a1), np.sin(a2), np.cos(a2)])
        worst[k] = np.abs(trig[:m] - want).max()
    assert max(worst[k] for k in range(1, kernels.TRIG_ANCHOR)) < 1e-14
    assert max(worst.values()) < 2e-13 and max(worst.values()) > 0.0


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_excited_steps_with_rotated_references_equal_fresh_ones_to_round_off(robot):
    """A communication step of 0.1 s with the excitation on (references rotated between fresh
    evaluations) against the same 100 RK4 steps one call each (every reference evaluated
    afresh): the same state to round-off, and the same result again for the same calls."""
    sc = scenario(robot)

    def plant():
        p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  sc.excitation)
        p.set_excitation(1.0)
        p.advance(2.0)                               # into the ramp
        return p

    a, b, c = plant(), plant(), plant()
    a.advance(0.1)
    c.advance(0.1)
    for _ in range(100):
        b.rk4_step(sc.h)
    assert a.t == b.t
    for x, y in ((a.q, b.q), (a.v, b.v), (a.J, b.J), (a.H, b.H)):
        np.testing.assert_allclose(x, y, rtol=1e-11, atol=1e-13)
    assert not np.array_equal(a.v, b.v)              # the rotation is used, and differs
    assert np.array_equal(a.v, c.v) and np.array_equal(a.q, c.q)


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_control_kernel_with_excitation_matches_reference(robot):
    """With the excitation on (mid-ramp and after it), the kernel is eq. 39 about the attitude
    reference and the posture law about the joint reference, as written out with NumPy."""
    from spacerobot.robots import Excitation

    sc = scenario(robot)
    ex = Excitation(att_max=0.2, q_max=0.5, qd_max=0.3, qdd_max=0.2, period=12.0, ramp=4.0)
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h, ex)
    plant.set_excitation(0.8)
    model, data = plant.pm.model, plant.pm.model.createData()
    r = 1 if plant.pm.planar else 3
    tab = ex.channels(r, plant.pm.n)
    for _ in range(12):
        plant.advance(0.5)
        q, v, t = plant.q.copy(), plant.v.copy(), plant.t
        M = pin.crba(model, data, q).copy()
        nle = pin.nonLinearEffects(model, data, q, v).copy()
        hg = pin.computeCentroidalMomentum(model, data, q, v).vector.copy()
        ramp = plant.get_state()["excite_ramp"]
        refs = _numpy_references(t, ramp, tab, r)
        assert np.abs(refs[3]).max() > 0.0
        out = _run_kernel(plant.pm.planar, q, v, M, nle, hg, sc.controller, plant.q_home, t, ramp,
                          tab)
        ref = reference_control(plant.pm.planar, q, v, M, nle, hg, sc.controller, plant.q_home,
                                refs)
        for x, y in zip(out, ref):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-8 * np.abs(y).max())
        # sines' work arrays that do not fit the table: evaluated in the call, the same law
        for nv_other in (len(v) - 2, len(v) + 3):
            other = _run_kernel(plant.pm.planar, q, v, M, nle, hg, sc.controller, plant.q_home,
                                t, ramp, tab, work_nv=nv_other)
            for x, y in zip(other, out):
                assert np.array_equal(x, y)
        # and it differs from the law without excitation
        off = _run_kernel(plant.pm.planar, q, v, M, nle, hg, sc.controller, plant.q_home)
        assert np.abs(off[2] - out[2]).max() > 1e-6


def test_control_kernel_damped_branch():
    """A nearly singular attitude coupling (two rotational rows of M_bm almost parallel): the
    selectively damped inverse is used, and matches the reference."""
    rng = np.random.default_rng(7)
    sc = scenario("spatial")
    c = sc.controller
    nb, n = 6, 6
    Mbb = np.diag([500.0, 500.0, 500.0, 80.0, 90.0, 100.0])
    Mbm = rng.normal(size=(nb, n))
    Mbm[5] = Mbm[4] * (1.0 + 1e-4)
    Mmm = 5.0 * np.eye(n) + Mbm.T @ np.linalg.solve(Mbb, Mbm)
    M = np.block([[Mbb, Mbm], [Mbm.T, Mmm]])
    G = np.linalg.solve(Mbb, Mbm)[3:6]
    lam = np.linalg.eigvalsh(G @ np.linalg.solve(Mmm, G.T))
    assert lam[0] / lam[-1] < kernels.DLS_RATIO                  # the damped branch
    q = np.concatenate([[0.1, 0.2, 0.3], [0.1, -0.2, 0.05, 0.97], rng.normal(size=n)])
    q[3:7] /= np.linalg.norm(q[3:7])
    v = rng.normal(size=nb + n) * 0.05
    nle = rng.normal(size=nb + n)
    hg = np.array([3.0, -20.0, 0.5, 4.0, -0.2, 30.0])
    out = _run_kernel(False, q, v, M, nle, hg, c, np.zeros(n))
    ref = reference_control(False, q, v, M, nle, hg, c, np.zeros(n))
    for x, r in zip(out, ref):
        np.testing.assert_allclose(x, r, rtol=0, atol=1e-9 * np.abs(r).max())


def test_control_kernel_reports_singular_inertia():
    sc = scenario("planar")
    nv = 6
    par = np.array([getattr(sc.controller, k) for k in kernels.PARAMS], float)
    q = np.array([0.0, 0.0, 1.0, 0.0, 0.1, 0.2, 0.3])
    args = (q, np.zeros(nv))
    bufs = (np.zeros(nv), np.zeros(nv), np.zeros(6), kernels.control_work(True, nv))
    M = np.zeros((nv, nv))
    ex = (0.0, NO_RAMP, NO_TAB)
    assert kernels.control(True, *args, M, np.zeros(nv), np.zeros(6), par, np.zeros(3), *ex,
                           *bufs) == 1
    M = np.diag([1.0, 1.0, 1.0, 0.0, 1.0, 1.0])
    assert kernels.control(True, *args, M, np.zeros(nv), np.zeros(6), par, np.zeros(3), *ex,
                           *bufs) == 2


# -- the persistent kernel cache -------------------------------------------------------------------

def test_load_uses_a_content_addressed_copy(tmp_path, monkeypatch):
    pkg = tmp_path / "src" / "srjit_demo"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kern.py").write_text("VALUE = 42\n")
    monkeypatch.syspath_prepend(str(tmp_path / "src"))
    import srjit_demo  # noqa: F401
    try:
        cache = tmp_path / "cache"
        monkeypatch.setenv("SPACEROBOT_CACHE_DIR", str(cache))
        mod = jit.load("srjit_demo", "kern")
        assert mod.VALUE == 42 and sys.modules["srjit_demo.kern"] is mod
        assert Path(mod.__file__).parent.parent == cache
        assert jit.load("srjit_demo", "kern") is mod                # idempotent
        # an unwritable cache location: imported from where it is
        del sys.modules["srjit_demo.kern"]
        blocker = tmp_path / "a_file"
        blocker.write_text("")
        monkeypatch.setenv("SPACEROBOT_CACHE_DIR", str(blocker))
        with pytest.warns(RuntimeWarning, match="cannot be written"):
            mod = jit.load("srjit_demo", "kern")
        assert Path(mod.__file__) == pkg / "kern.py"
    finally:
        for m in [m for m in sys.modules if m.startswith("srjit_demo")]:
            del sys.modules[m]


def test_compiled_kernels_are_reused_by_a_new_process(tmp_path):
    """First process: compiles into the cache. Second process: loads from it (no compilation)."""
    code = (
        "import json, numpy as np\n"
        "from spacerobot.plant import Plant, kernels, rigid_body\n"
        "from spacerobot.robots import scenario\n"
        "sc = scenario('planar')\n"
        "p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)\n"
        "p.outputs()\n"                                  # measure: the initial state
        "p.advance(0.01)\n"                              # advance_measured
        "p.outputs()\n"
        "st = {k: [sum(getattr(f.stats, 'cache_' + w).values()) for w in ('hits', 'misses')]\n"
        "      for k, f in (('measure', kernels.measure),\n"
        "                   ('advance', kernels.advance_measured))}\n"
        "print(json.dumps({'file': kernels.__file__, 'stats': st, 'x': p.q.tolist()}))\n")
    env = dict(os.environ, SPACEROBOT_CACHE_DIR=str(tmp_path))
    runs = [json.loads(subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, check=True,
                                      capture_output=True, text=True).stdout.splitlines()[-1])
            for _ in range(2)]
    assert all(Path(r["file"]).is_relative_to(tmp_path) for r in runs)
    assert runs[0]["stats"]["measure"][1] >= 1                 # compiled (cache miss)
    for name in ("measure", "advance"):
        hits, misses = runs[1]["stats"][name]
        assert hits >= 1 and misses == 0
    assert list((tmp_path).glob("kernels-*/__pycache__/*.nbi"))
    assert list((tmp_path).glob("rigid_body-*/__pycache__/*.nbi"))
    assert runs[0]["x"] == runs[1]["x"]                        # same machine code, same result


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_outputs_measured_with_the_step_equal_a_measure_of_their_own(robot):
    """The outputs a step measures in its own compiled call (kernels.advance_measured) equal,
    bit for bit, those measured afresh at the same state (a copy of the plant, whose restored
    state has none yet: kernels.measure), excited and not, and so do the controls; after
    set_excitation the outputs are measured again (the level's ramp starts there)."""
    import copy
    sc = scenario(robot)
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              sc.excitation)
    for k in range(6):
        if k == 2:
            p.set_excitation(1.0)
        p.advance(0.1 if k != 4 else 0.0375)              # a partial last RK4 step too
        twin = copy.deepcopy(p)
        a, b = p.output_vector(), twin.output_vector()
        assert np.array_equal(a, b)
        ca, cb = p.controls(), twin.controls()
        for f in ("F", "M", "tau", "a"):
            assert np.array_equal(getattr(ca, f), getattr(cb, f)), f
    p.set_excitation(0.0)
    twin = copy.deepcopy(p)
    assert np.array_equal(p.output_vector(), twin.output_vector())
