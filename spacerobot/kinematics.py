"""Rigid-body kinematics of the described robot in plain numpy (no Pinocchio).

Used by the estimator (it must not depend on the plant) and by the tests as an independent
cross-check of Pinocchio. All vectors are in the inertial frame unless the name says ``_B``.

Recursion for revolute joint ``i`` with parent frame ``p`` (origin ``r_p``, DCM ``A_p``):

    d   = A_p xyz_i                      r_i = r_p + d
    A_i = A_p R_i Rot(axis_i, q_i)       z   = A_i axis_i
    w_i = w_p + z qd_i                   b_i = b_p + z qdd_i + w_p x z qd_i
    v_i = v_p + w_p x d                  a_i = a_p + b_p x d + w_p x (w_p x d)

(``w`` angular velocity, ``b`` angular acceleration, ``v``/``a`` of the frame origin.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robots import Robot


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix, ``skew(a) @ b == a x b`` (paper eq. 14)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit vector ``axis`` (Rodrigues)."""
    K = skew(axis)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


@dataclass
class BodyMotion:
    """Motion of a set of bodies (arrays stacked over bodies, first axis = body).

    Attributes
    ----------
    r, v, a : (k, 3)   centre-of-mass position, velocity, acceleration
    A : (k, 3, 3)      DCM body -> inertial
    w, beta : (k, 3)   angular velocity and acceleration
    """

    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    A: np.ndarray
    w: np.ndarray
    beta: np.ndarray


@dataclass
class FrameMotion:
    """Motion of one frame origin: position, DCM, velocities and accelerations (inertial)."""

    r: np.ndarray
    A: np.ndarray
    v: np.ndarray
    w: np.ndarray
    a: np.ndarray
    beta: np.ndarray


class ArmKinematics:
    """Forward kinematics of the arm links and the end-effector frame E.

    Parameters
    ----------
    robot : Robot
        The robot description (only the arm geometry and link inertias are used).
    """

    def __init__(self, robot: Robot):
        self.robot = robot
        self.n = robot.n_joints
        self.xyz = np.array([l.xyz for l in robot.links], dtype=float)
        self.R = np.array([l.R() for l in robot.links])
        self.axis = np.array([l.axis for l in robot.links], dtype=float)
        self.axis /= np.linalg.norm(self.axis, axis=1)[:, None]
        self.mass = np.array([l.body.mass for l in robot.links])
        self.com = np.array([l.body.com for l in robot.links], dtype=float)
        self.I = np.array([l.body.inertia_matrix() for l in robot.links])
        self.ee_xyz = np.array(robot.ee_xyz, dtype=float)
        self.ee_R = robot.ee_R()

    def compute(self, r_S, A_B, v_S, omega_B, a_S, alpha_B, q, qd, qdd):
        """Link centre-of-mass motion and end-effector frame motion.

        Parameters
        ----------
        r_S, v_S, a_S : (3,)   base sensor point position, velocity, acceleration (inertial)
        A_B : (3, 3)           base DCM body -> inertial
        omega_B, alpha_B : (3,) base angular velocity and acceleration, base frame
        q, qd, qdd : (n,)      joint angles, rates, accelerations

        Returns
        -------
        links : BodyMotion with k = n arm links (centre-of-mass quantities)
        ee : FrameMotion of the end-effector frame E
        """
        n = self.n
        r_p = np.asarray(r_S, float)
        A_p = np.asarray(A_B, float)
        w_p = A_p @ np.asarray(omega_B, float)
        b_p = A_p @ np.asarray(alpha_B, float)  # d/dt(A w_B) = A dw_B/dt since w x w = 0
        v_p = np.asarray(v_S, float)
        a_p = np.asarray(a_S, float)
        r = np.empty((n, 3)); v = np.empty((n, 3)); a = np.empty((n, 3))
        A = np.empty((n, 3, 3)); w = np.empty((n, 3)); beta = np.empty((n, 3))
        for i in range(n):
            d = A_p @ self.xyz[i]
            r_i = r_p + d
            v_i = v_p + np.cross(w_p, d)
            a_i = a_p + np.cross(b_p, d) + np.cross(w_p, np.cross(w_p, d))
            A_i = A_p @ self.R[i] @ axis_angle(self.axis[i], q[i])
            z = A_i @ self.axis[i]
            w_i = w_p + z * qd[i]
            b_i = b_p + z * qdd[i] + np.cross(w_p, z) * qd[i]
            c = A_i @ self.com[i]
            r[i] = r_i + c
            v[i] = v_i + np.cross(w_i, c)
            a[i] = a_i + np.cross(b_i, c) + np.cross(w_i, np.cross(w_i, c))
            A[i], w[i], beta[i] = A_i, w_i, b_i
            r_p, A_p, w_p, b_p, v_p, a_p = r_i, A_i, w_i, b_i, v_i, a_i
        d = A_p @ self.ee_xyz
        ee = FrameMotion(r=r_p + d, A=A_p @ self.ee_R, v=v_p + np.cross(w_p, d), w=w_p,
                         a=a_p + np.cross(b_p, d) + np.cross(w_p, np.cross(w_p, d)), beta=b_p)
        return BodyMotion(r, v, a, A, w, beta), ee

    # -- sums over the known arm links ---------------------------------------------------
    def momentum(self, links: BodyMotion):
        """Linear momentum and angular momentum about the inertial origin of the arm links.

        P = sum m_i v_i ;  L = sum A_i I_i A_i^T w_i + m_i r_i x v_i   (paper eqs. 7-8)
        """
        P = self.mass @ links.v
        Iw = np.einsum("kij,kjl,kml,km->ki", links.A, self.I, links.A, links.w)
        L = Iw.sum(0) + np.cross(links.r, self.mass[:, None] * links.v).sum(0)
        return P, L

    def rate_of_momentum(self, links: BodyMotion, r_ref: np.ndarray):
        """Force and moment about the point ``r_ref`` needed to move the arm links.

        F = sum m_i a_i ;  M = sum I_i b_i + w_i x I_i w_i + m_i (r_i - r_ref) x a_i  (eqs. 26-27)
        """
        F = self.mass @ links.a
        Iw_world = np.einsum("kij,kjl,kml->kim", links.A, self.I, links.A)
        Ib = np.einsum("kij,kj->ki", Iw_world, links.beta)
        Iw = np.einsum("kij,kj->ki", Iw_world, links.w)
        M = (Ib + np.cross(links.w, Iw)).sum(0) + np.cross(
            links.r - r_ref, self.mass[:, None] * links.a).sum(0)
        return F, M


def body_momentum(m, b, I_c, r_O, A, v_O, w):
    """Momentum of one rigid body given its frame origin motion.

    Parameters
    ----------
    m : float; b : (3,) CoM offset in body frame; I_c : (3, 3) CoM inertia in body frame
    r_O, v_O : (3,) frame origin position and velocity; A : (3, 3) DCM; w : (3,) inertial

    Returns
    -------
    P : (3,) linear momentum;  L : (3,) angular momentum about the inertial origin
    """
    c = A @ b
    r_c, v_c = r_O + c, v_O + np.cross(w, c)
    return m * v_c, A @ I_c @ A.T @ w + m * np.cross(r_c, v_c)
