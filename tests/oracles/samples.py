"""Test helpers shared by the information-filter tests and benchmarks/modal_information.py: a
scenario's inertial parameters as the 20-vector the filter reports (per body: mass, centre of
mass, inertia about the centre of mass in the body frame), and a measured sample as the flat
vector the native core reads. Plain data shaping, no mathematics of the library."""
from __future__ import annotations

import numpy as np

from .estimator.identifier import KEYS      # the flat sample's groups, in order


def body10(b) -> list:
    """One body's 10 parameters: mass, centre of mass (3), inertia (xx yy zz xy xz yz)."""
    return [float(b.mass), *map(float, b.com), *map(float, b.inertia)]


def truth_of(sc) -> np.ndarray:
    """The scenario's true base and target (20,)."""
    return np.array(body10(sc.robot.base) + body10(sc.target))


def guess_of(sc) -> np.ndarray:
    """The scenario's a-priori guess of base and target (20,)."""
    return np.array(body10(sc.guess.base) + body10(sc.guess.target))


def flat(o) -> np.ndarray:
    """A sample (mapping of KEYS to arrays) as one flat float vector."""
    return np.concatenate([np.ravel(o[k]) for k in KEYS]).astype(float)
