"""Run metrics of the Monte Carlo study (spacerobot.system.mc_metrics) on constructed series."""
import math

import numpy as np

from spacerobot.system.mc_metrics import rise_time, run_metrics, settle_time

T = np.arange(0.0, 10.01, 1.0)          # 11 points


def test_settle_time_is_the_last_entry_into_the_band():
    err = np.array([1, .5, .009, .02, .008, .005, .004, .003, .002, .001, .0005])
    assert settle_time(T, err, 1e-2) == 4.0          # 0.02 at t = 3 re-enters later
    assert settle_time(T, err, 1e-3) == 10.0
    assert math.isnan(settle_time(T, err, 1e-4))
    assert settle_time(T, np.zeros(11), 1e-3) == 0.0
    assert math.isnan(settle_time(T, np.full(11, np.nan), 1.0))


def test_rise_time():
    assert rise_time(T, np.array([0] * 5 + [1] * 6)) == 5.0
    assert math.isnan(rise_time(T, np.zeros(11)))


def test_run_metrics_columns():
    truth = np.arange(1.0, 21.0)
    scale = np.abs(truth)
    est = np.tile(truth, (11, 1))
    est[:6, 3] = truth[3] * 1.05                   # base parameter 5 % off until t = 5
    est[:8, 15] = truth[15] * 1.002                # target parameter 0.2 % off until t = 7
    ident = np.zeros((11, 2))
    ident[4:, 0] = 1                               # base flagged at t = 4, while 5 % off: false
    ident[9:, 1] = 1                               # target flagged at t = 9: honest
    excite = np.array([1, 1, 1, 1, .5, 0, 0, 0, 0, 0, 0])
    m = run_metrics(T, est, truth, scale, ident, np.ones(11, bool), excite,
                    {"base": range(10), "target": range(10, 20)})
    assert m["worst_error"] == 0.0 and m["t_1pct"] == 6.0 and m["t_01pct"] == 8.0
    assert m["identified.base"] == 1 and m["t_identified.base"] == 4.0
    assert m["false_identified.base"] == 1 and m["false_identified.target"] == 0
    assert m["t_identified.target"] == 9.0 and m["physical"] == 1
    assert m["t_excite_off"] == 4.0 and m["excite_mean"] == np.mean(excite)
    # only the identified estimates count (a planar robot's out-of-plane guesses do not)
    est[:, 9] = 1e3
    m2 = run_metrics(T, est, truth, scale, ident, np.ones(11, bool), excite,
                     {"base": range(9), "target": range(10, 20)})
    assert m2["worst_error"] == 0.0
    m3 = run_metrics(T, est, truth, scale, ident, np.r_[np.ones(10, bool), False], excite,
                     {"base": range(10), "target": range(10, 20)})
    assert m3["physical"] == 0 and m3["worst_error"] > 10
