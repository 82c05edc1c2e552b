"""Interface conformance: the bad-input catalogue of the FMI 2.0 FMUs.

One table (CATALOGUE) of bad inputs, each with the FMI status it must get, the message the FMU
must log, and what must survive (docs/fmus.md, "Status mapping"); nothing is ever logged with
status Fatal:

- estimator samples that are non-finite, not a rotation, or so large that the update would
  overflow: OK, a logged warning, ``diag.status`` 3/4, ``diag.rejected`` + 1, every other output
  bit-identical to before, and the run continues exactly as the estimator core run without that
  sample (an independent computation with spacerobot.estimator.Identifier);
- a sensors input beyond the range the FMU declares: OK with a warning naming it, the run goes
  on;
- invalid parameters (masses <= 0, inertias not positive definite or violating the triangle
  inequality, non-finite values, h, bounds, lambda, covariances, unknown method/solver/
  accel_source): Error at fmi2ExitInitializationMode with a logged error naming the parameter;
  the instance can be freed and a new instance in the same process runs normally;
- communication steps that are zero, negative, non-finite or (plant) longer than 100 s, and
  non-finite communication points: Discard with a message; a communication point other than
  the FMU's time: Error with a message; in both cases every output unchanged, and the run
  continues exactly as a run that never saw the call;
- calls out of lifecycle order, setting an output, a wrong type or an unknown value reference:
  Discard (doStep) or Error (the others) with a message, state unchanged.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import pytest

from spacerobot.fmi.native import LOG_CATEGORIES

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import (DISCARD, DT, ERROR, FATAL, OK, ROBOTS, WARNING, Inst,
                                   assert_same, fed_inputs, fmus_for, plant_samples)

N, K = 8, 4          # runs of 8 steps of 0.1 s; the bad input comes at step K
NAN, INF = float("nan"), float("inf")


@dataclass(frozen=True)
class Bad:
    id: str
    kind: str                    # plant | estimator | sensors
    stage: str                   # param | sample | input | step | order | running
    arg: object                  # see the runners below
    status: int                  # FMI status of the offending call
    message: str                 # regex the logged message must match
    log_status: Optional[int] = None   # status the message was logged with
    diag: Optional[int] = None   # estimator diag.status after a bad sample
    robots: tuple = field(default=ROBOTS)


# lifecycle-order cases: set the instance up, return (offending call, args, how to go on)
def _order_before_init(inst):
    return inst.step, (0.0, DT), lambda: inst.init()


def _order_in_init_mode(inst):
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    return inst.step, (0.0, DT), inst.fmu.exitInitializationMode


def _order_exit_without_enter(inst):
    inst.fmu.setupExperiment(startTime=0.0)
    return (inst.fmu.fmi2ExitInitializationMode, (inst.fmu.component,),
            lambda: (inst.fmu.enterInitializationMode(), inst.fmu.exitInitializationMode()))


CATALOGUE = [
    # -- estimator samples -------------------------------------------------------------------
    Bad("nan-velocity", "estimator", "sample", ("base.v[1]", NAN), OK,
        r"sample skipped .*non-finite.*base\.v\[1\].*estimates unchanged", WARNING, diag=3),
    Bad("inf-impulse", "estimator", "sample", ("thrust.J[2]", INF), OK,
        r"sample skipped .*non-finite.*thrust\.J\[2\]", WARNING, diag=3),
    Bad("minus-inf-joint", "estimator", "sample", ("arm.q[1]", -INF), OK,
        r"sample skipped .*arm\.q\[1\]", WARNING, diag=3),
    Bad("nan-dcm", "estimator", "sample", ("base.A[2,2]", NAN), OK,
        r"sample skipped .*non-finite", WARNING, diag=3),
    Bad("dcm-not-rotation", "estimator", "sample", ("base.A[1,1]", 2.0), OK,
        r"sample skipped .*not a rotation", WARNING, diag=4),
    Bad("overflowing-position", "estimator", "sample", ("base.r[1]", 1e300), OK,
        r"sample skipped .*\[input base\.r\[1\]\].*beyond the physical range.*SI units", WARNING,
        diag=3),
    Bad("overflowing-velocity", "estimator", "sample", ("base.v[1]", 1e200), OK,
        r"sample skipped .*\[input base\.v\[1\]\].*beyond the physical range", WARNING, diag=3),
    # -- parameters, refused at fmi2ExitInitializationMode ------------------------------------
    Bad("negative-base-mass", "plant", "param", {"base.m": -1.0}, ERROR,
        r"base\.m must be > 0 kg", ERROR),
    Bad("zero-target-mass", "plant", "param", {"target.m": 0.0}, ERROR,
        r"target\.m must be > 0 kg", ERROR),
    Bad("inertia-not-positive-definite", "plant", "param", {"base.Ixx": -1.0}, ERROR,
        r"base inertia must be positive definite", ERROR),
    Bad("inertia-product-too-large", "plant", "param", {"target.Ixy": 1e3}, ERROR,
        r"target inertia must be positive definite", ERROR),
    Bad("inertia-triangle-inequality", "plant", "param",
        {"target.Ixx": 10.0, "target.Iyy": 1.0, "target.Izz": 1.0}, ERROR,
        r"target inertia violates the triangle inequality", ERROR),
    Bad("nan-com", "plant", "param", {"base.b[1]": NAN}, ERROR,
        r"non-finite parameter value\(s\): base\.b\[1\] = nan", ERROR),
    Bad("zero-internal-step", "plant", "param", {"h": 0.0}, ERROR, r"h must be within \[1e-06, 1\] s", ERROR),
    Bad("long-internal-step", "plant", "param", {"h": 2.0}, ERROR, r"h must be within \[1e-06, 1\] s", ERROR),
    Bad("negative-force-bound", "plant", "param", {"F_max": -1.0}, ERROR, r"F_max must be within \[0, 1e\+09\] N", ERROR),
    Bad("zero-guess-mass", "estimator", "param", {"guess.base.m": 0.0}, ERROR,
        r"guess\.base\.m must be > 0 kg", ERROR),
    Bad("negative-guess-mass", "estimator", "param", {"guess.target.m": -5.0}, ERROR,
        r"guess\.target\.m must be > 0 kg", ERROR),
    Bad("guess-inertia-triangle", "estimator", "param",
        {"guess.target.Ixx": 30.0, "guess.target.Iyy": 10.0, "guess.target.Izz": 10.0}, ERROR,
        r"guess\.target inertia violates the triangle inequality", ERROR),
    Bad("infinite-guess-inertia", "estimator", "param", {"guess.target.Izz": INF}, ERROR,
        r"non-finite parameter value\(s\): guess\.target\.Izz = inf", ERROR),
    Bad("zero-forgetting-factor", "estimator", "param", {"lambda": 0.0}, ERROR,
        r"lambda must satisfy 0 < lambda <= 1, got 0", ERROR),
    Bad("forgetting-factor-above-one", "estimator", "param", {"lambda": 1.5}, ERROR,
        r"lambda must satisfy 0 < lambda <= 1, got 1.5", ERROR),
    Bad("negative-covariance", "estimator", "param", {"P0_mu": -1.0}, ERROR,
        r"P0_mu must be a finite covariance > 0", ERROR),
    Bad("nan-covariance", "estimator", "param", {"P0_theta": NAN}, ERROR,
        r"non-finite parameter value\(s\): P0_theta = nan", ERROR),
    Bad("unknown-method", "estimator", "param", {"method": 3}, ERROR,
        r"method = 3 is not one of 1 \(momentum\), 2 \(force\)", ERROR),
    Bad("unknown-method-zero", "estimator", "param", {"method": 0}, ERROR,
        r"method = 0 is not one of", ERROR),
    Bad("unknown-solver", "estimator", "param", {"solver": 7}, ERROR,
        r"solver = 7 is not one of 1 \(paper\), 2 \(joint\)", ERROR),
    Bad("negative-noise", "sensors", "param", {"noise.gyro.arw": -1.0}, ERROR,
        r"noise\.gyro\.arw must be finite and >= 0", ERROR),
    Bad("nan-noise-scale", "sensors", "param", {"noise.scale": NAN}, ERROR,
        r"non-finite parameter value\(s\): noise\.scale = nan", ERROR),
    Bad("negative-delay", "sensors", "param", {"noise.delay": -1}, ERROR,
        r"noise\.delay must be an integer in 0\.\.100", ERROR),
    Bad("imu-flag-not-0-or-1", "sensors", "param", {"noise.imu": 2}, ERROR,
        r"noise\.imu must be 0 or 1", ERROR),
    Bad("unknown-accel-source", "estimator", "param", {"accel_source": -1}, ERROR,
        r"accel_source = -1 is not one of 1 \(measured\), 2 \(differenced\)", ERROR),
    # -- communication steps ------------------------------------------------------------------
    *[Bad(f"{kind}-step-{label}", kind, "step", (0.0, dt), DISCARD,
          r"communication step .* rejected: it must be finite and in \(0, "
          + ("100" if kind == "plant" else "inf") + r"\] s", DISCARD)
      for kind in ("plant", "estimator", "sensors")
      for label, dt in (("zero", 0.0), ("negative", -DT), ("nan", NAN), ("inf", INF))],
    Bad("plant-step-longer-than-100s", "plant", "step", (0.0, 100.001), DISCARD,
        r"communication step 100\.001 s .* rejected: .*\(0, 100\] s", DISCARD),
    Bad("plant-step-1e9s", "plant", "step", (0.0, 1e9), DISCARD, r"\(0, 100\] s", DISCARD),
    Bad("plant-nan-communication-point", "plant", "step", (NAN, DT), DISCARD,
        r"non-finite communication point nan", DISCARD),
    Bad("estimator-nan-communication-point", "estimator", "step", (NAN, DT), DISCARD,
        r"non-finite communication point nan", DISCARD),
    # a step from another time than the FMU's: refused by the layer, every model alike
    *[Bad(f"{kind}-communication-point-off", kind, "step", (5.0, DT), ERROR,
          r"fmi2DoStep: the communication point 5 s differs from the FMU's time 0\.4\d* s .*"
          r"step refused, state unchanged", ERROR)
      for kind in ("plant", "estimator", "sensors")],
    *[Bad(f"{kind}-communication-point-a-hair-off", kind, "step", (K * DT * (1 + 1e-6), DT),
          ERROR, r"differs from the FMU's time", ERROR)
      for kind in ("plant", "estimator", "sensors")],
    # sensors inputs outside the range they declare: measured as they are, with a warning
    Bad("sensors-input-beyond-range", "sensors", "input", ("true.base.r[2]", 1e300), OK,
        r"t = 0\.4 s: input\(s\) true\.base\.r\[2\] non-finite or beyond the physical range "
        r"\|x\| <= 1e\+15", WARNING),
    # accepted, documented: the estimator has no longest step (it works per sample)
    Bad("estimator-step-1e9s", "estimator", "step", (0.0, 1e9), OK, r"^$"),
    # -- lifecycle order ----------------------------------------------------------------------
    *[Bad(f"{kind}-doStep-before-initialisation", kind, "order", _order_before_init, DISCARD,
          r"doStep called in phase 'instantiated'; call fmi2ExitInitializationMode first")
      for kind in ("plant", "estimator", "sensors")],
    *[Bad(f"{kind}-doStep-in-initialisation-mode", kind, "order", _order_in_init_mode, DISCARD,
          r"doStep called in phase 'initialization'")
      for kind in ("plant", "estimator", "sensors")],
    *[Bad(f"{kind}-exit-without-enter", kind, "order", _order_exit_without_enter, ERROR,
          r"fmi2ExitInitializationMode called in phase 'instantiated'; call "
          r"fmi2EnterInitializationMode first", ERROR)
      for kind in ("plant", "estimator", "sensors")],
    *[Bad(f"{kind}-{what}", kind, "running", what, status, msg, log)
      for kind in ("plant", "estimator", "sensors")
      for what, status, msg, log in (
          ("enter-initialisation-while-stepping", ERROR,
           r"fmi2EnterInitializationMode called in phase 'stepping'; it is only allowed once", ERROR),
          ("set-an-output", ERROR, r"is an output and cannot be set", ERROR),
          ("setInteger-on-a-Real", ERROR, r"fmi2SetInteger: .* is not of type Integer", ERROR),
          ("unknown-value-reference", ERROR, r"fmi2GetReal: unknown value reference 99999", ERROR),
          ("doStep-after-terminate", DISCARD, r"doStep called in phase 'terminated'", None))],
]


def _ids():
    return [f"{b.id}" for b in CATALOGUE]


@pytest.fixture(params=ROBOTS)
def robot(request):
    return request.param


def _matching(messages, pattern, log_status):
    if pattern == "^$":
        return not messages
    return any(re.search(pattern, m, re.S) and (log_status is None or s == log_status)
               for s, _, m in messages)


def _reference(fmus, kind, names, samples, n=N, skip=None):
    """Outputs of an undisturbed FMU run of ``n`` steps (optionally skipping sample ``skip``)."""
    inst = Inst(fmus[kind], "reference").init()
    fed = fed_inputs(kind, names)
    for k in range(n):
        if fed is not None:
            inst.set_many(fed, samples[k])
        assert inst.step(k * DT, DT) == OK
    out = inst.outputs()
    inst.free()
    return out


def _core_without(robot, names, samples, skip, n=N):
    """Independent computation: the estimator core (no FMI) over samples 0..n-1 except ``skip``;
    returns its estimate vector and sample count."""
    from spacerobot.estimator import Identifier
    from spacerobot.interface import measurement_vars
    from spacerobot.robots import scenario

    sc = scenario(robot)
    ident = Identifier(sc.robot, sc.guess, method="momentum", solver="paper",
                       accel_source="measured", lam=1.0)
    keys = {v.name: v.key for v in measurement_vars(sc.robot.n_joints, "input")}
    for k in range(n):
        if k == skip:
            continue
        meas = {}
        for name, x in zip(names, samples[k]):
            group, idx = keys[name]
            shape = (3, 3) if group == "A" else (sc.robot.n_joints if group in ("q", "qd", "qdd")
                                                 else 3)
            meas.setdefault(group, np.zeros(shape))[idx] = x
        ident.update(k * DT, meas)
    return ident.report().vector, ident.samples


ESTIMATES = [f"{who}.{p}" for who in ("base", "target")
             for p in ("m", "b[1]", "b[2]", "b[3]", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")]


@pytest.mark.parametrize("bad", CATALOGUE, ids=_ids())
def test_bad_input(request, robot, bad):
    if robot not in bad.robots:
        pytest.skip("not for this robot")
    fmus = fmus_for(request, robot)
    names, samples = plant_samples(fmus, N)
    kind = bad.kind
    inst = Inst(fmus[kind], "bad")

    fed = fed_inputs(kind, names)

    def advance(k0, k1, t0=None):
        """Samples k0..k1-1 in good steps of DT, from k0 DT (or from t0)."""
        for k in range(k0, k1):
            if fed is not None:
                inst.set_many(fed, samples[k])
            t = k * DT if t0 is None else t0 + (k - k0) * DT
            assert inst.step(t, DT) == OK

    if bad.stage == "param":
        fresh = _reference(fmus, kind, names, samples, n=2)
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        for name, value in bad.arg.items():
            inst.set(name, value)
        status, msgs = inst.call(inst.fmu.fmi2ExitInitializationMode, inst.fmu.component)
        _check(bad, status, msgs)
        inst.free()                                   # must not crash
        # nothing lost for the process: a new instance runs as before
        assert_same(_reference(fmus, kind, names, samples, n=2), fresh, "new instance after it")
        return

    if bad.stage == "order":
        fn, args, go_on = bad.arg(inst)
        status, msgs = inst.call(fn, *args)
        _check(bad, status, msgs)
        go_on()                 # the regular lifecycle from there on, as if nothing happened
        advance(0, N)
        got = inst.outputs()
        inst.free()
        assert_same(got, _reference(fmus, kind, names, samples), "run after the bad call")
        return

    inst.init()
    advance(0, K)
    before = inst.outputs()

    def bad_sample_step():
        """Sample K with the bad value, one step: the status and messages checked."""
        name, value = bad.arg
        s = samples[K].copy()
        s[fed.index(name)] = value
        inst.set_many(fed, s)
        status, msgs = inst.call(inst.step, K * DT, DT)
        _check(bad, status, msgs)

    if bad.stage == "sample":
        bad_sample_step()
        after = inst.outputs()
        assert after["diag.status"] == bad.diag
        assert after["diag.rejected"] == before["diag.rejected"] + 1
        keep = [n for n in before if n not in ("diag.status", "diag.rejected")]
        assert_same({n: after[n] for n in keep}, {n: before[n] for n in keep},
                    "outputs after the rejected sample")
        advance(K + 1, N)
        got = inst.outputs()
        inst.free()
        est, used = _core_without(robot, names, samples, skip=K)
        assert got["diag.samples"] == used
        assert_same({n: got[n] for n in ESTIMATES}, dict(zip(ESTIMATES, map(float, est))),
                    "FMU with a bad sample vs core without it")
        return

    if bad.stage == "step":
        t_off, dt = bad.arg
        t = K * DT if t_off == 0.0 else t_off
        if fed is not None:
            inst.set_many(fed, samples[K])
            before = inst.outputs()      # a direct feedthrough (sensors) follows its inputs
        status, msgs = inst.call(inst.step, t, dt)
        _check(bad, status, msgs)
        if status in (DISCARD, ERROR):
            assert_same(inst.outputs(), before, "outputs after the refused step")
            advance(K, N)                          # retry from t_K with good steps
        else:                                      # the accepted step consumed sample K
            advance(K + 1, N, t0=t + dt)           # and the next step starts where it ended
        got = inst.outputs()
        inst.free()
        assert_same(got, _reference(fmus, kind, names, samples), "run after the bad step")
        return

    if bad.stage == "input":
        bad_sample_step()
        advance(K + 1, N)                          # the run goes on
        inst.free()
        return

    assert bad.stage == "running"
    what = bad.arg
    name = "base.m" if kind == "estimator" else "base.r[1]"     # outputs of each
    if what == "enter-initialisation-while-stepping":
        status, msgs = inst.call(inst.fmu.fmi2EnterInitializationMode, inst.fmu.component)
    elif what == "set-an-output":
        status, msgs = inst.call(inst.set, name, 1.0)
    elif what == "setInteger-on-a-Real":
        from fmpy.fmi2 import fmi2Integer, fmi2ValueReference

        vr = (fmi2ValueReference * 1)(inst.vars[name].valueReference)
        status, msgs = inst.call(inst.fmu.fmi2SetInteger, inst.fmu.component, vr, 1,
                                 (fmi2Integer * 1)(1))
    elif what == "unknown-value-reference":
        status, msgs = inst.call(inst.fmu.getReal, [99999])
    else:
        inst.fmu.terminate()
        status, msgs = inst.call(inst.step, K * DT, DT)
    _check(bad, status, msgs)
    assert_same(inst.outputs(), before, "outputs after the refused call")
    if what != "doStep-after-terminate":
        advance(K, N)
        got = inst.outputs()
        assert_same(got, _reference(fmus, kind, names, samples), "run after the refused call")
    inst.free()


def _check(bad, status, msgs):
    names = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal"}
    assert status == bad.status, f"status {names.get(status)} (expected {names[bad.status]}); {msgs}"
    assert _matching(msgs, bad.message, bad.log_status), (bad.message, msgs)
    assert all(st < FATAL for st, _, _ in msgs), f"a message logged as Fatal: {msgs}"
    assert {c for _, c, _ in msgs} <= set(LOG_CATEGORIES), msgs   # declared categories only


def test_catalogue_covers_every_category():
    stages = {b.stage for b in CATALOGUE}
    assert stages == {"param", "sample", "input", "step", "order", "running"}
    assert len({b.id for b in CATALOGUE}) == len(CATALOGUE)
