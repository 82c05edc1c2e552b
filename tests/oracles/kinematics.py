"""Test oracle: rigid-body kinematics of the described robot in plain NumPy (no Pinocchio, no
Numba), the reference that the estimator's compiled kernels and the plant's Pinocchio model are
checked against. Not part of the library (it does not ship in the FMUs). All vectors are in the
inertial frame unless the name says ``_B``.

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

from .estimator.layout import arm_arrays


class ArmGeometry:
    """The known arm of a robot description as arrays (:func:`.estimator.layout.arm_arrays`):
    ``xyz``, ``R``, ``axis``, ``mass``, ``com``, ``I``, ``ee_xyz``, ``ee_R``; ``n`` joints."""

    def __init__(self, robot):
        self.robot = robot
        self.n = len(robot.links)
        (self.xyz, self.R, self.axis, self.mass, self.com, self.I, self.ee_xyz,
         self.ee_R) = arm_arrays(robot)

    def arrays(self):
        """``(xyz, R, axis, mass, com, I, ee_xyz, ee_R)``, the arguments of
        :func:`oracles.estimator.kernels.equations`."""
        return self.xyz, self.R, self.axis, self.mass, self.com, self.I, self.ee_xyz, self.ee_R


def cross3(a, b) -> np.ndarray:
    """``a x b`` for two 3-vectors (explicit formula)."""
    a0, a1, a2 = a[0], a[1], a[2]
    b0, b1, b2 = b[0], b[1], b[2]
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix, ``skew(a) @ b == a x b`` (paper eq. 14)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


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


#: ``skew(a).ravel() == a @ _SKEW9`` (row-major 3x3), for stacks of cross-product matrices
_SKEW9 = np.zeros((3, 9))
_SKEW9[2, 1] = _SKEW9[0, 5] = _SKEW9[1, 6] = -1.0
_SKEW9[1, 2] = _SKEW9[2, 3] = _SKEW9[0, 7] = 1.0


def skew_stack(V: np.ndarray) -> np.ndarray:
    """Cross-product matrices of the rows of ``V`` (k, 3): (k, 3, 3)."""
    return V.dot(_SKEW9).reshape(-1, 3, 3)


class ArmKinematics(ArmGeometry):
    """Forward kinematics of the arm links and the end-effector frame E.

    Parameters
    ----------
    robot : the robot description (only the arm geometry and link inertias are used).

    Notes
    -----
    :meth:`compute` evaluates the recursion of the module docstring for all links at once:
    the joint rotations by a vectorised Rodrigues formula, the DCM chain by n small products,
    and the velocity / acceleration recursions as cumulative sums of batched cross products.
    """

    def __init__(self, robot):
        super().__init__(robot)
        n = self.n
        # R_i Rot(axis_i, q) = R_i + sin(q) R_i K_i + (1 - cos(q)) R_i K_i^2, K_i = skew(axis_i)
        K = skew_stack(self.axis)
        self._rod = np.stack([self.R, self.R @ K, self.R @ K @ K], axis=1).reshape(n, 3, 9)
        self._coef = np.ones((n, 1, 3))
        # local vectors per frame j = 0 (base) .. n: [offset of the next frame, axis_j, com_j]
        loc = np.zeros((n + 1, 3, 3))
        loc[:n, :, 0] = self.xyz
        loc[n, :, 0] = self.ee_xyz
        loc[1:, :, 1] = self.axis
        loc[1:, :, 2] = self.com
        self._loc = loc
        self._m3 = self.mass[:, None]
        self._tri = np.tril(np.ones((n + 2, n + 2)))

    def compute(self, r_S, A_B, v_S, omega_B, a_S, alpha_B, q, qd, qdd, accelerations=True):
        """Link centre-of-mass motion and end-effector frame motion.

        Parameters
        ----------
        r_S, v_S, a_S : (3,)   base sensor point position, velocity, acceleration (inertial)
        A_B : (3, 3)           base DCM body -> inertial
        omega_B, alpha_B : (3,) base angular velocity and acceleration, base frame
        q, qd, qdd : (n,)      joint angles, rates, accelerations
        accelerations : bool   False: skip the accelerations (``a``, ``beta`` are then None;
                               ``a_S``, ``alpha_B``, ``qdd`` are not used)

        Returns
        -------
        links : BodyMotion with k = n arm links (centre-of-mass quantities)
        ee : FrameMotion of the end-effector frame E
        """
        n = self.n
        A_B = np.asarray(A_B, float)
        q = np.asarray(q, float)
        qd = np.asarray(qd, float)[:, None]
        w0 = A_B.dot(np.asarray(omega_B, float))
        # joint rotations and the DCM chain
        coef = self._coef
        coef[:, 0, 1] = np.sin(q)
        coef[:, 0, 2] = 1.0 - np.cos(q)
        L = np.matmul(coef, self._rod).reshape(n, 3, 3)
        Aall = np.empty((n + 1, 3, 3))
        Aall[0] = A_B
        for i in range(n):
            np.dot(Aall[i], L[i], out=Aall[i + 1])
        Wl = np.matmul(Aall, self._loc)          # (n+1, 3, 3): [d, z, c] in the inertial frame
        D = Wl[:, :, 0]                          # offset of frame j+1 (E for j = n) from frame j
        Z = Wl[1:, :, 1]
        C = Wl[1:, :, 2]
        # angular velocity (and acceleration) of frames 0..n: running sums as products with a
        # lower-triangular matrix of ones; row 0 of the summands is the base's value
        T = self._tri
        Zs = np.empty((n + 1, 3))
        Zs[0] = w0
        Zqd = np.multiply(Z, qd, out=Zs[1:])
        Wall = T[1:, 1:].dot(Zs)
        Sw = skew_stack(Wall)                                   # [w_j]x, j = 0..n
        # frame j carries d_j (to the next frame) and c_j (its link's centre of mass)
        DC = Wl[:, :, 0::2]
        X1 = np.matmul(Sw, DC)                                  # w x d, w x c
        A = Aall[1:]
        w = Wall[1:]
        nrow = 3 if accelerations else 2
        inc = np.empty((nrow, n + 2, 3))                        # r_j, v_j (a_j) increments
        inc[0, 0], inc[1, 0] = r_S, v_S
        inc[0, 1:], inc[1, 1:] = D, X1[:, :, 0]
        if accelerations:
            b0 = A_B.dot(np.asarray(alpha_B, float))  # d/dt(A w_B) = A dw_B/dt: w x w = 0
            Bs = np.empty((n + 1, 3))
            Bs[0] = b0
            np.multiply(Z, np.asarray(qdd, float)[:, None], out=Bs[1:])
            Bs[1:] += np.matmul(Sw[:n], Zqd[:, :, None])[:, :, 0]   # + w_p x z qd
            Ball = T[1:, 1:].dot(Bs)
            X2 = np.matmul(skew_stack(Ball), DC)                # b x d, b x c
            X2 += np.matmul(Sw, X1)                             # + w x (w x d), w x (w x c)
            inc[2, 0] = a_S
            inc[2, 1:] = X2[:, :, 0]
        O = np.matmul(T, inc)                  # frame origins 0..n and E
        # centres of mass of the links
        r = O[0, 1:n + 1] + C
        v = O[1, 1:n + 1] + X1[1:, :, 1]
        if accelerations:
            a = O[2, 1:n + 1] + X2[1:, :, 1]
            beta = Ball[1:]
            ee_a, ee_beta = O[2, n + 1], beta[n - 1]
        else:
            a = beta = ee_a = ee_beta = None
        ee = FrameMotion(r=O[0, n + 1], A=A[n - 1].dot(self.ee_R), v=O[1, n + 1], w=w[n - 1],
                         a=ee_a, beta=ee_beta)
        return BodyMotion(r, v, a, A, w, beta), ee

    # -- sums over the known arm links ---------------------------------------------------
    def momentum(self, links: BodyMotion):
        """Linear momentum and angular momentum about the inertial origin of the arm links.

        P = sum m_i v_i ;  L = sum A_i I_i A_i^T w_i + m_i r_i x v_i   (paper eqs. 7-8)
        """
        A = links.A
        P = self.mass.dot(links.v)
        wl = np.matmul(links.w[:, None, :], A)                       # (A^T w)^T
        Iw = np.matmul(A, np.matmul(self.I, wl.transpose(0, 2, 1)))   # A I A^T w
        mv = self._m3 * links.v
        L = Iw.sum(0)[:, 0] + np.matmul(skew_stack(links.r), mv[:, :, None]).sum(0)[:, 0]
        return P, L

    def rate_of_momentum(self, links: BodyMotion, r_ref: np.ndarray):
        """Force and moment about the point ``r_ref`` needed to move the arm links.

        F = sum m_i a_i ;  M = sum I_i b_i + w_i x I_i w_i + m_i (r_i - r_ref) x a_i  (eqs. 26-27)
        """
        A = links.A
        F = self.mass.dot(links.a)
        Wb = np.stack([links.beta, links.w], axis=2)                  # (n, 3, 2)
        Ib_Iw = np.matmul(A, np.matmul(self.I, np.matmul(A.transpose(0, 2, 1), Wb)))
        ma = self._m3 * links.a
        M = (Ib_Iw[:, :, 0]
             + np.matmul(skew_stack(links.w), Ib_Iw[:, :, 1:])[:, :, 0]
             + np.matmul(skew_stack(links.r - r_ref), ma[:, :, None])[:, :, 0]).sum(0)
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
    r_c, v_c = r_O + c, v_O + cross3(w, c)
    return m * v_c, A @ I_c @ A.T @ w + m * cross3(r_c, v_c)
