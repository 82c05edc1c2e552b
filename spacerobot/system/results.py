"""Metrics of run results by name: the relative error of estimates keyed by estimate name,
computed by :func:`spacerobot.interface.relative_errors` (one definition of the metric)."""
from __future__ import annotations

from typing import Dict, Mapping

import numpy as np

from .. import interface


def relative_errors(est: Mapping[str, float], truth: Mapping[str, float]) -> Dict[str, float]:
    """``|est - truth| / interface.error_scale(truth)`` for every name of
    :data:`interface.ESTIMATE_NAMES` that has both an estimate and a truth (a missing truth
    counts as zero in the scale of its body)."""
    names = interface.ESTIMATE_NAMES
    t = np.array([float(truth.get(p, 0.0)) for p in names])
    e = np.array([float(est[p]) if est.get(p) is not None else np.nan for p in names])
    rel = interface.relative_errors(e, t)
    return {p: float(r) for p, r in zip(names, rel)
            if est.get(p) is not None and truth.get(p) is not None}
