"""The interface table's estimate names and identified sets agree with the estimator core; the
parameter layout, the estimator's codes (reaching the native core) and the error metric."""
import re
from pathlib import Path

import numpy as np
import pytest

from spacerobot.estimator import Identifier
from oracles.estimator import parameters as par
from spacerobot.interface import (ACCEL_SOURCES, ESTIMATE_NAMES, METHODS, SOLVERS, AccelSource,
                                  Method, ParameterLayout, Solver, error_scale, estimate_vector,
                                  estimator_vars, identified_estimates, relative_errors,
                                  relative_errors_by_name)
from spacerobot.plant import Plant
from spacerobot.robots import PLANAR, SPATIAL, Guess, RigidBody, scenario


def test_identified_estimates_are_as_documented():
    assert identified_estimates(PLANAR) == [
        "base.m", "base.b[1]", "base.b[2]", "base.Izz",
        "target.m", "target.b[1]", "target.b[2]", "target.Izz"]
    assert identified_estimates(SPATIAL) == list(ESTIMATE_NAMES) and len(ESTIMATE_NAMES) == 20


def test_estimate_names_are_estimator_outputs():
    outputs = [v.name for v in estimator_vars(PLANAR, scenario("planar"))
               if v.causality == "output" and not v.name.startswith(("sd.", "crb.", "diag.", "ident."))]
    assert outputs == list(ESTIMATE_NAMES)


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_exactly_the_identified_estimates_move(robot):
    """Run the core: the estimates that change are exactly identified_estimates(robot)."""
    sc = scenario(robot)
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
    ident = Identifier(sc.robot, sc.guess, "force")
    start = ident.vector()
    for _ in range(20):
        ident.update(p.t, p.outputs())
        p.advance(0.1)
    moved = [n for n, a, b in zip(ESTIMATE_NAMES, start, ident.vector()) if a != b]
    assert moved == identified_estimates(sc.robot)
    assert np.all(np.isfinite(ident.vector()))


# ------------------------------------------------------------------------------------------------
# the parameter layout, the codes and the error metric
# ------------------------------------------------------------------------------------------------

#: two bodies whose every parameter differs, so that a wrong position shows
BASE = RigidBody(500.0, (0.11, -0.12, 0.13), (81.0, 82.0, 83.0, -1.1, 1.2, -1.3))
TARGET = RigidBody(250.0, (0.21, 0.22, -0.23), (11.0, 12.0, 13.0, 0.31, -0.32, 0.33))


@pytest.mark.parametrize("robot", [PLANAR, SPATIAL], ids=["planar", "spatial"])
def test_layout_positions_mean_what_they_say(robot):
    """Each identified entry of mu, theta and the standard parameters, found through the layout,
    holds the quantity of the estimate of the same name (computed here from its definition)."""
    L = ParameterLayout.for_robot(robot)
    names = identified_estimates(robot)
    assert [n for n, ok in zip(L.names, L.identified) if ok] == names
    g = Guess(BASE, TARGET, 1.0, 1.0)
    mu, th = par.paper_vectors(g)
    std = par.standard_vector((BASE, TARGET))
    expect_mu, expect_th, expect_std = [], [], []
    for who, body in (("base", BASE), ("target", TARGET)):
        I = body.inertia_matrix()
        com = np.array(body.com)
        I_O = I + body.mass * (com @ com * np.eye(3) - np.outer(com, com))
        ij = {"Ixx": (0, 0), "Iyy": (1, 1), "Izz": (2, 2), "Ixy": (0, 1), "Ixz": (0, 2),
              "Iyz": (1, 2)}
        first = [body.mass] + [body.mass * c for c in com]
        expect_mu += [x for x, p in zip(first, ("m", "b[1]", "b[2]", "b[3]"))
                      if f"{who}.{p}" in names]
        expect_std += [x for x, p in zip(first, ("m", "b[1]", "b[2]", "b[3]"))
                       if f"{who}.{p}" in names]
        # inertia entries in the paper's I# order (I11, I12, I13, I22, I23, I33)
        for p in ("Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"):
            if f"{who}.{p}" in names:
                expect_th.append(I[ij[p]])
                expect_std.append(I_O[ij[p]])
    np.testing.assert_allclose(mu[L.mu_active], expect_mu, rtol=1e-15)
    np.testing.assert_allclose(th[L.theta_active], expect_th, rtol=1e-15)
    np.testing.assert_allclose(std[L.standard_active], expect_std, rtol=1e-15)
    # rows: planar x, y translation and z rotation
    assert L.rows_lin.tolist() == ([0, 1] if robot.planar else [0, 1, 2])
    assert L.rows_ang.tolist() == ([2] if robot.planar else [0, 1, 2])


def test_layout_per_body_views_and_masks():
    L = ParameterLayout()
    vec = estimate_vector(BASE, TARGET)
    views = L.per_body(vec)
    for who, body in (("base", BASE), ("target", TARGET)):
        b = L.body(who)
        np.testing.assert_array_equal(views[who], [body.mass, *body.com, *body.inertia])
        assert vec[b.m] == body.mass and list(vec[b.first]) == list(body.com)
        assert list(vec[b.principal]) == list(body.inertia[:3])
        assert [L.names[i] for i in range(20) if L.first_order[i] and L.names[i].startswith(who)] \
            == [f"{who}.{p}" for p in ("m", "b[1]", "b[2]", "b[3]")]
    assert L.per_body(np.zeros((7, 20)))["target"].shape == (7, 10)
    assert L.index("target.Izz") == 16


def test_codes_are_defined_once_and_parse_labels_codes_and_members():
    assert METHODS == {1: "momentum", 2: "force"} and SOLVERS == {1: "paper", 2: "joint"}
    assert ACCEL_SOURCES == {1: "measured", 2: "differenced"}
    assert Method.parse("force") is Method.FORCE is Method.parse(2) is Method.parse(Method.FORCE)
    assert Solver.parse(np.int32(2)) is Solver.JOINT and AccelSource.parse("differenced") == 2
    for bad in (3, 0, "Force", 1.0, True, None):
        with pytest.raises(ValueError,
                           match=r"method = .* is not one of 1 \(momentum\), 2 \(force\)"):
            Method.parse(bad, "method")
    # the FMI parameter descriptions name the same codes
    desc = {v.name: v.description for v in estimator_vars(PLANAR, scenario("planar"))}
    assert "1 = momentum-based" in desc["method"] and "2 = force-based" in desc["method"]
    assert "2 = joint RLS" in desc["solver"] and "2 = derivatives of the velocity inputs" in desc["accel_source"]


def test_identifier_takes_labels_codes_or_members_alike():
    sc = scenario("planar")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
    outs = []
    for _ in range(6):
        outs.append((p.t, p.outputs()))
        p.advance(0.1)
    a = Identifier(sc.robot, sc.guess, "force", "joint", "differenced")
    b = Identifier(sc.robot, sc.guess, Method.FORCE, Solver.JOINT, AccelSource.DIFFERENCED)
    c = Identifier(sc.robot, sc.guess, 2, 2, 2)
    for t, o in outs:
        for ident in (a, b, c):
            ident.update(t, o)
    # the codes reach the native core's options
    for ident in (a, b, c):
        o = ident.core.options
        assert (o.method, o.solver, o.accel_source) == (2, 2, 2)
    assert a.solver_kind is Solver.JOINT and a.samples == len(outs) - 2   # differencing delay
    np.testing.assert_array_equal(a.vector(), b.vector())
    np.testing.assert_array_equal(a.vector(), c.vector())
    d = Identifier(sc.robot, sc.guess)
    assert d.solver_kind is Solver.PAPER and d.core.options.solver == 1
    with pytest.raises(ValueError, match="solver = 'batch' is not one of 1 \\(paper\\)"):
        Identifier(sc.robot, sc.guess, solver="batch")


def test_error_metric_is_finite_for_zero_truth_and_scaled_as_documented():
    truth = estimate_vector(RigidBody(400.0, (0.0, 0.5, 0.01), (10.0, 20.0, 30.0, 0.0, -2.0, 0.0)),
                            RigidBody(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
    est = truth + 0.01
    s = error_scale(truth)
    # |truth|; a CoM component -> at least 5 cm; a product of inertia (zero or not) -> the
    # largest moment (30); a body with no mass and no inertia at all -> 1 kg, 5 cm, 1 kg.m2
    np.testing.assert_array_equal(s[:10], [400, 0.05, 0.5, 0.05, 10, 20, 30, 30, 30, 30])
    np.testing.assert_array_equal(s[10:], [1.0] + [0.05] * 3 + [1.0] * 6)
    rel = relative_errors(est, truth)
    assert np.all(np.isfinite(rel))
    np.testing.assert_allclose(rel, 0.01 / s, rtol=1e-12)
    # by name: the same numbers, for the names present on both sides
    e = dict(zip(ESTIMATE_NAMES, est))
    t = dict(zip(ESTIMATE_NAMES, truth))
    del e["base.m"]
    by_name = relative_errors_by_name(e, t)
    assert set(by_name) == set(ESTIMATE_NAMES) - {"base.m"}
    np.testing.assert_allclose([by_name[n] for n in ESTIMATE_NAMES[1:]], rel[1:], rtol=1e-15)


def test_no_bare_parameter_offsets_outside_the_layout_and_the_kernels():
    """Positions of parameters are written once (interface.ParameterLayout) in the Python
    package (the native core keeps its own, native/src)."""
    root = Path(__file__).resolve().parents[1]
    files = list((root / "spacerobot" / "estimator").glob("*.py"))
    pattern = re.compile(r"\b(10|4|6) \* k\b|\b8 \+ 6\b|% 10\b|\[5, 11\]|\[0, 1, 2, 9\]")
    hits = [f"{p.name}:{i + 1}: {line.strip()}" for p in files
            for i, line in enumerate(p.read_text().splitlines()) if pattern.search(line)]
    assert not hits, hits
