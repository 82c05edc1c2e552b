"""Label -> FMI code of the estimator's integer parameters, the one inverse of the code ->
label tables :data:`spacerobot.interface.METHODS`, :data:`~spacerobot.interface.SOLVERS` and
:data:`~spacerobot.interface.ACCEL_SOURCES` (used by the command line and the sweeps)."""
from __future__ import annotations

from typing import Dict, Mapping

from ..interface import ACCEL_SOURCES, METHODS, SOLVERS


def codes(labels: Mapping[int, str]) -> Dict[str, int]:
    """``{code: label}`` -> ``{label: code}``."""
    return {label: code for code, label in labels.items()}


METHOD_CODES = codes(METHODS)            #: ``{"momentum": 1, "force": 2}``
SOLVER_CODES = codes(SOLVERS)            #: ``{"paper": 1, "joint": 2}``
ACCEL_CODES = codes(ACCEL_SOURCES)       #: ``{"measured": 1, "differenced": 2}``


def estimator_overrides(method: str, accel_source: str,
                        solver: str | None = None) -> Dict[str, int]:
    """The SSP overrides ``estimator.method``, ``estimator.accel_source`` (and
    ``estimator.solver``) of the labels; KeyError naming the known labels otherwise."""
    out = {}
    for key, label, table in (("method", method, METHOD_CODES),
                              ("accel_source", accel_source, ACCEL_CODES),
                              ("solver", solver, SOLVER_CODES)):
        if label is None:
            continue
        if label not in table:
            raise KeyError(f"{key} must be one of {sorted(table)}, got {label!r}")
        out[f"estimator.{key}"] = table[label]
    return out
