"""Build the FMUs of a scenario: the plant, the estimator and the sensors, each the C core's
FMI 2.0 or FMI 3.0 binaries packaged with the scenario's data (:mod:`.native`).

``build_fmu`` is the library's and the command line's one way to an FMU; it needs no compiler
(the install step compiled the binaries) and no Python at the FMU's run time.
"""
from __future__ import annotations

from pathlib import Path

from ..robots import Scenario
from .native import FMI_VERSIONS, MODELS, build_native_fmu


def build_fmu(kind: str, sc: Scenario, out_dir: str | Path, fmi_version: int = 2) -> Path:
    """Build the FMU ``kind`` ('plant', 'estimator' or 'sensors') of the scenario ``sc`` into
    ``out_dir``, as an FMI ``fmi_version`` (2 or 3) co-simulation FMU; returns its path."""
    if kind not in MODELS:
        raise ValueError(f"kind must be one of {sorted(MODELS)}, got {kind!r}")
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"fmi_version must be one of {FMI_VERSIONS}, got {fmi_version!r}")
    return build_native_fmu(kind, sc, out_dir, fmi_version=fmi_version)
