"""The arm's constant geometry as arrays: what the robot record carries and the compiled
kinematics read.

The estimator's equations of a sample (native/src/equations.c, through the robot record;
the tests' NumPy oracle tests/oracles/estimator/kernels.py) evaluate the arm's
forward kinematics from :class:`ArmGeometry`; the NumPy reference of the same recursion that
the tests check them against lives outside the library (``tests/oracles/kinematics.py``), so
that it does not ship in the FMUs.
"""
from __future__ import annotations

import numpy as np

from .robots import Robot


class ArmGeometry:
    """The known arm of a robot as contiguous float arrays (n = number of joints).

    Attributes
    ----------
    xyz : (n, 3)       joint placement in the parent frame [m]
    R : (n, 3, 3)      joint frame orientation in the parent frame
    axis : (n, 3)      unit joint axis, joint frame
    mass : (n,)        link masses [kg]
    com : (n, 3)       link centres of mass, link frame [m]
    I : (n, 3, 3)      link inertias about their centres of mass, link frame [kg.m2]
    ee_xyz : (3,)      end-effector frame E (the target frame) in the last link's frame [m]
    ee_R : (3, 3)      its orientation
    """

    def __init__(self, robot: Robot):
        self.robot = robot
        self.n = robot.n_joints
        c = np.ascontiguousarray
        self.xyz = c([l.xyz for l in robot.links], dtype=float)
        self.R = c([l.R() for l in robot.links], dtype=float)
        axis = np.array([l.axis for l in robot.links], dtype=float)
        self.axis = c(axis / np.linalg.norm(axis, axis=1)[:, None])
        self.mass = c([l.body.mass for l in robot.links], dtype=float)
        self.com = c([l.body.com for l in robot.links], dtype=float)
        self.I = c([l.body.inertia_matrix() for l in robot.links], dtype=float)
        self.ee_xyz = c(robot.ee_xyz, dtype=float)
        self.ee_R = c(robot.ee_R(), dtype=float)

    def arrays(self):
        """``(xyz, R, axis, mass, com, I, ee_xyz, ee_R)``, the arguments of
        :func:`oracles.estimator.kernels.equations`."""
        return self.xyz, self.R, self.axis, self.mass, self.com, self.I, self.ee_xyz, self.ee_R
