"""The identified flags through the sensors never stand while their body is off (the flags'
hold, native/src/est_hold.c; docs/identification.md, "The identified flags").

Two random spatial targets of the Monte Carlo (seed 0) where the Bonferroni rule alone flagged
a body that was off: case 54 (the target flagged at 9.7 s, before the information filter's
replay, while its mass estimate was 92 t for 282 kg) and case 188 (the target flagged from
272 s while its estimates drifted 0.16-0.21 % below the truth, 7 sd). Through plant ->
sensors -> estimator for 300 s (the ``realistic`` set), checked against the plant's truth at
every sample: a body flagged has every identified estimate within the flag's threshold
(``ident.sd_rel`` = 0.1 % of its error scale)."""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot import interface
from spacerobot.system.montecarlo import SensorsCase, build_sensors_system
from spacerobot.system.runner import run_ssp

THRESHOLD = 1e-3


@pytest.fixture(scope="module")
def sensors_ssp(tmp_path_factory):
    return str(build_sensors_system("spatial", tmp_path_factory.mktemp("hold"))["ssp"])


@pytest.mark.slow
@pytest.mark.parametrize("index", [54, 188])
def test_no_body_is_flagged_while_it_is_off(sensors_ssp, index):
    case = SensorsCase("spatial", index, 0, "force", "closed", 300.0, "differenced",
                       noise_scale=1.0)
    res = run_ssp(sensors_ssp, stop_time=case.stop_time, overrides=case.fmi_overrides(),
                  progress=False)
    names = interface.ESTIMATE_NAMES
    truth = np.array([res.truth[n] for n in names])
    est = np.column_stack([res.data[f"estimator.{n}"] for n in names])
    rel = np.abs(est - truth) / interface.error_scale(truth)
    robot = case.scenario().robot
    ident = np.array([n in set(interface.identified_estimates(robot)) for n in names])
    for k, who in enumerate(("base", "target")):
        flag = np.asarray(res.data[f"estimator.diag.identified.{who}"]) > 0.5
        body = ident & (np.arange(20) // 10 == k)
        off = rel[:, body].max(axis=1) > THRESHOLD
        assert not np.any(flag & off), (who, res.time[flag & off][:5])
