"""The identified flags through the sensors and their hold (native/src/est_hold.c;
docs/identification.md, "The flags' hold" and "A known limit").

Two random spatial targets of the Monte Carlo (seed 0), through plant -> sensors -> estimator
(the ``realistic`` set), checked against the plant's truth at every sample: a body flagged
must have every identified estimate within the flag's threshold (``ident.sd_rel`` = 0.1 % of
its error scale).

* Case 54: the Bonferroni rule alone flagged the target at 9.7 s, before the information
  filter's replay, while its mass estimate was 92 t for 282 kg. With the hold no flag stands
  while the body is off over 300 s, and the target's flag does rise (at about 199 s).
* Case 188: its thrust misalignment's second-order part, which the filter does not model,
  biases every mass and inertia by 0.14-0.17 % (6-8 sd). The hold keeps the flags down while
  the estimates drift (to about 315 s) but not once they settle: the target is flagged off
  from 315 s, the base from 414 s. A known limit, run to 450 s as an expected failure (strict:
  the day the thrust model takes it, this test says so)."""
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


def _flags_while_off(ssp: str, index: int, stop_time: float):
    """Per body: (the flag at every sample, whether the body was off at it)."""
    case = SensorsCase("spatial", index, 0, "force", "closed", stop_time, "differenced",
                       noise_scale=1.0)
    res = run_ssp(ssp, stop_time=case.stop_time, overrides=case.fmi_overrides(),
                  progress=False)
    names = interface.ESTIMATE_NAMES
    truth = np.array([res.truth[n] for n in names])
    est = np.column_stack([res.data[f"estimator.{n}"] for n in names])
    rel = np.abs(est - truth) / interface.error_scale(truth)
    ident = np.isin(names, interface.identified_estimates(case.scenario().robot))
    out = {}
    for k, who in enumerate(("base", "target")):
        flag = np.asarray(res.data[f"estimator.diag.identified.{who}"]) > 0.5
        body = ident & (np.arange(20) // 10 == k)
        out[who] = (flag, rel[:, body].max(axis=1) > THRESHOLD)
    return res.time, out


@pytest.mark.slow
def test_no_flag_before_the_replay_and_none_while_off(sensors_ssp):
    t, bodies = _flags_while_off(sensors_ssp, 54, 300.0)
    for who, (flag, off) in bodies.items():
        assert not np.any(flag & off), (who, t[flag & off][:5])
        assert not np.any(flag[t < 120.0]), who      # the replay (60 s) and the hold (60 s)
    assert bodies["target"][0][-1], "the target's flag should rise (about 199 s)"


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="known limit: the thrust misalignment's second-order "
                   "part biases case 188 by 6-8 sd (docs/identification.md, 'A known limit')")
def test_a_misalignment_bias_the_filter_does_not_model(sensors_ssp):
    t, bodies = _flags_while_off(sensors_ssp, 188, 450.0)
    for who, (flag, off) in bodies.items():
        assert not np.any(flag & off), (who, t[flag & off][:5])
