"""Sweep points: one co-simulation's parameters (:class:`Point`), its stable id, the grid of
points (:func:`make_points`) and the truth a point expects."""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Tuple

from ...interface import ESTIMATE_NAMES, estimate_vector, identified_estimates
from ...robots import (BUILTIN_ROBOTS, DEFAULT_TARGET, INERTIA_NAMES, ROBOTS, TARGETS,
                       get_robot, robot_kind, robot_spec, scenario)
from ..codes import ACCEL_CODES, METHOD_CODES, estimator_overrides

#: every estimated parameter, in the order of ``Identifier.vector()``
PARAMS: Tuple[str, ...] = ESTIMATE_NAMES

#: the parameters each robot identifies (the planar model: x, y translation, z rotation)
IDENTIFIED = {name: tuple(identified_estimates(robot)) for name, robot in ROBOTS.items()}


@dataclass(frozen=True)
class Point:
    """One co-simulation of the sweep. ``v0`` is always stored as a 3-vector."""

    robot: str = "planar"
    target: Optional[str] = None        #: None: the robot's default target
    method: str = "momentum"
    accel_source: str = "measured"
    v0: Tuple[float, float, float] = (1.0, 2.0, 0.0)
    F_max: float = 10.0
    stop_time: float = 30.0
    overrides: Tuple[Tuple[str, float], ...] = field(default_factory=tuple)

    def __post_init__(self):
        if self.robot not in BUILTIN_ROBOTS:      # a URDF file: its absolute key, checked
            object.__setattr__(self, "robot", robot_spec(self.robot))
            get_robot(self.robot)
        if self.target is None:
            object.__setattr__(self, "target", DEFAULT_TARGET[robot_kind(self.robot)])
        v = tuple(float(x) for x in self.v0)
        if len(v) == 2:
            v = v + (0.0,)
        if len(v) != 3:
            raise ValueError(f"v0 must have 2 or 3 components, got {self.v0!r}")
        object.__setattr__(self, "v0", v)
        object.__setattr__(self, "F_max", float(self.F_max))
        object.__setattr__(self, "stop_time", float(self.stop_time))
        ov = self.overrides.items() if isinstance(self.overrides, Mapping) else self.overrides
        object.__setattr__(self, "overrides",
                           tuple(sorted((str(k), float(x)) for k, x in ov)))
        if self.method not in METHOD_CODES:
            raise ValueError(f"method must be one of {sorted(METHOD_CODES)}, got {self.method!r}")
        if self.accel_source not in ACCEL_CODES:
            raise ValueError(f"accel source must be one of {sorted(ACCEL_CODES)}, "
                             f"got {self.accel_source!r}")
        if self.target not in TARGETS[robot_kind(self.robot)]:
            raise ValueError(f"target must be one of {sorted(TARGETS[robot_kind(self.robot)])} "
                             f"for robot {self.robot!r}, got {self.target!r}")

    def canonical(self) -> dict:
        """The parameters that identify the point (what :func:`point_id` hashes)."""
        return {"robot": self.robot, "target": self.target, "method": self.method,
                "accel_source": self.accel_source, "v0": [repr(x) for x in self.v0],
                "F_max": repr(self.F_max), "stop_time": repr(self.stop_time),
                "overrides": [[k, repr(x)] for k, x in self.overrides]}

    @property
    def id(self) -> str:
        return point_id(self)

    def fmi_overrides(self) -> Dict[str, float]:
        """The SSP runner overrides of this point (component-prefixed FMI names)."""
        body = TARGETS[robot_kind(self.robot)][self.target]
        ov: Dict[str, float] = {"plant.target.m": body.mass}
        ov.update({f"plant.target.b[{i + 1}]": float(body.com[i]) for i in range(3)})
        ov.update({f"plant.target.{n}": float(body.inertia[k])
                   for k, n in enumerate(INERTIA_NAMES)})
        ov.update({f"plant.base.v0[{i + 1}]": self.v0[i] for i in range(3)})
        ov["plant.F_max"] = self.F_max
        ov.update(estimator_overrides(self.method, self.accel_source))
        ov.update(dict(self.overrides))
        return ov

    def columns(self) -> Dict[str, object]:
        return {"sweep_id": self.id, "robot": self.robot, "target": self.target,
                "method": self.method, "accel_source": self.accel_source,
                "v0_x": self.v0[0], "v0_y": self.v0[1], "v0_z": self.v0[2],
                "v0_norm": math.sqrt(sum(x * x for x in self.v0)),
                "F_max": self.F_max, "stop_time": self.stop_time,
                "overrides": json.dumps(dict(self.overrides), sort_keys=True)}


def point_id(point: Point) -> str:
    """Stable 16-hex-digit hash of the point's parameters (sha256 of canonical JSON).

    Independent of the process, the Python hash seed and the order of overrides; ``v0 = [0, 10]``
    and ``[0, 10, 0]`` are the same point.
    """
    text = json.dumps(point.canonical(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _as_list(x) -> list:
    if x is None:
        return []
    if isinstance(x, (list, tuple)):
        return list(x)
    return [x]


def make_points(robot="planar", target=None, method=("momentum", "force"),
                accel=("measured",), v0=None, F_max=None, stop_time=None,
                overrides: Optional[Mapping[str, float]] = None) -> List[Point]:
    """The Cartesian product of the given values, in a stable order, without duplicates.

    Every argument takes a single value or a list. ``None`` (target, v0, F_max, stop_time)
    means the robot's paper scenario value (:func:`spacerobot.robots.scenario`), e.g. planar:
    medium target, v0 = [1, 2] m/s, F_max = 10 N, 30 s. The momentum method does not use
    accelerations, so it is run once per grid point, with the first acceleration source.
    """
    robots = _as_list(robot)
    out: List[Point] = []
    seen = set()
    accels = _as_list(accel) or ["measured"]
    for rb in robots:
        sc = scenario(rb)
        v0s = list(v0) if v0 is not None else [sc.v0]
        if v0s and not isinstance(v0s[0], (list, tuple)):
            v0s = [v0s]
        targets = _as_list(target) or [DEFAULT_TARGET[robot_kind(rb)]]
        fms = _as_list(F_max) or [sc.controller.F_max]
        sts = _as_list(stop_time) or [sc.stop_time]
        for tg, me, ac, v, fm, st in itertools.product(
                targets, _as_list(method), accels, v0s, fms, sts):
            if me == "momentum" and ac != accels[0]:
                continue
            p = Point(rb, tg, me, ac, tuple(v), fm, st, tuple((overrides or {}).items()))
            if p.id not in seen:
                seen.add(p.id)
                out.append(p)
    return out



def expected_truth(point: Point) -> Dict[str, float]:
    """Truth of the point from the robot, the target and the point's overrides."""
    robot = get_robot(point.robot)
    target = TARGETS[robot_kind(point.robot)][point.target]
    truth = dict(zip(PARAMS, estimate_vector(robot.base, target).tolist()))
    for k, x in point.overrides:
        if k.startswith("plant.") and k[6:] in truth:
            truth[k[6:]] = float(x)
    return truth
