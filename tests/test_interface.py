"""The interface table's estimate names and identified sets agree with the estimator core."""
import numpy as np
import pytest

from spacerobot.estimator import Identifier
from spacerobot.interface import ESTIMATE_NAMES, estimator_vars, identified_estimates
from spacerobot.plant import Plant
from spacerobot.robots import PLANAR, SPATIAL, scenario


def test_identified_estimates_are_as_documented():
    assert identified_estimates(PLANAR) == [
        "base.m", "base.b[1]", "base.b[2]", "base.Izz",
        "target.m", "target.b[1]", "target.b[2]", "target.Izz"]
    assert identified_estimates(SPATIAL) == list(ESTIMATE_NAMES) and len(ESTIMATE_NAMES) == 20


def test_estimate_names_are_estimator_outputs():
    outputs = [v.name for v in estimator_vars(PLANAR, scenario("planar"))
               if v.causality == "output" and not v.name.startswith(("sd.", "diag."))]
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
