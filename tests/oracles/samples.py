"""Test helpers shared by the information-filter, modal and misfit tests and
benchmarks/modal_information.py: a scenario's inertial parameters as the 20-vector the filter
reports (per body: mass, centre of mass, inertia about the centre of mass in the body frame), a
measured sample as the flat vector the native core reads, a parameter set's noise-free samples
from the native plant, and the estimator core as the FMU builds it from its parameters. Data
shaping and set-up, no mathematics of the library."""
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


def scenario_samples(sc, t_end: float, dt: float):
    """``(samples (K, len), composite truth (20,))``: the noise-free samples of scenario ``sc``
    every ``dt`` from 0 to ``t_end`` (the native plant with its excitation on) and the
    composite rigid truth the rigid model should converge to (flexible panels and slosh
    masses at rest)."""
    from spacerobot.core.plant import NativePlant
    from spacerobot.core.sample import sample_length
    plant = NativePlant.of(sc)
    plant.set_excitation(1.0)
    n = sample_length(plant.n)
    xs = [plant.output_vector()[:n].copy()]
    for _ in range(int(round(t_end / dt))):
        plant.advance(dt)
        xs.append(plant.output_vector()[:n].copy())
    base = plant.base_now()
    truth = np.r_[base.mass, base.com, base.inertia,
                  sc.target.mass, sc.target.com, sc.target.inertia]
    return np.array(xs), truth


def parameter_set_samples(robot: str, name: str, t_end: float, dt: float, amplitude=None):
    """``(scenario, samples, composite truth)`` of ``robot``'s parameter set ``name``
    (:func:`scenario_samples`; the excitation at ``amplitude`` [rad] for attitude and joints
    where given)."""
    from dataclasses import replace
    from spacerobot.robots import Excitation, parameter_set_scenario
    sc = parameter_set_scenario(robot, name)
    if amplitude is not None:
        sc = replace(sc, excitation=Excitation(att_max=amplitude, q_max=amplitude))
    return (sc, *scenario_samples(sc, t_end, dt))


def sensed(sc, XT, seed: int, dt: float) -> np.ndarray:
    """(K, len) the samples XT through the sensors FMU's realistic defaults (sensors seed)."""
    from spacerobot.sensors import SensorSuite
    suite = SensorSuite(sc.robot.n_joints, scale=1.0, seed=seed, dt=dt)
    return np.array([flat(suite.update(suite.sample(xt), dt)) for xt in XT])


def fmu_identifier(sc, dt: float, values):
    """The estimator core as the estimator FMU builds it for ``sc``: its parameters at their
    defaults with ``values`` (FMU parameter names) over them, sampled every ``dt``."""
    from spacerobot.estimator.identifier import identifier_from_values
    from spacerobot.interface import estimator_parameter_values
    v = estimator_parameter_values(sc.robot, sc)
    v.update(values)
    return identifier_from_values(sc.robot, v, dt)[0]
