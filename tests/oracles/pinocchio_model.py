"""Test oracle: the free-floating multibody model on Pinocchio (model building and the base
conventions), the independent reference the native plant's dynamics (native/src/dynamics.c,
plant.c) are checked against. Not part of the library (the plant runs on the C core).

:class:`PlantModel` is built once from a :class:`~spacerobot.robots.Robot` plus the base and
target truth; Pinocchio's algorithms (ABA, CRBA, RNEA, centroidal momentum) run on it.

Generalised coordinates (Pinocchio's):

* spatial: free-flyer root, ``q = [r_S (3), quat xyzw (4), q_arm]``,
  ``v = [v_S in base frame (3), omega_B (3), qd]``;
* planar: planar root, ``q = [x, y, cos(th), sin(th), q_arm]``, ``v = [v_S in base frame (2),
  omega_z, qd]``.

The ODE is written in these coordinates as an ordinary vector ODE (``dq/dt`` from ``v``
including the quaternion / (cos, sin) kinematics), so classic RK4 applies
unchanged and is fourth-order; the native plant uses the same coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from spacerobot.robots import RigidBody, Robot


@dataclass(frozen=True)
class PlantModel:
    """Pinocchio model of robot + base truth + rigidly attached target.

    Attributes
    ----------
    model : pin.Model        gravity-free model; root joint 1 is the base, joints 2.. the arm
    planar : bool
    nb : int                 base velocity dimension (6 spatial, 3 planar)
    n : int                  number of arm joints
    rot_rows : slice         rows of the base velocity that are the angular velocity
    ee_frame : int           Pinocchio frame id of the end-effector frame E
    """

    model: pin.Model
    robot: Robot
    base: RigidBody
    target: RigidBody
    planar: bool
    nb: int
    n: int
    rot_rows: slice
    ee_frame: int


def _inertia(body: RigidBody) -> pin.Inertia:
    return pin.Inertia(float(body.mass), np.array(body.com, float), body.inertia_matrix())


def build_model(robot: Robot, base: RigidBody | None = None, target: RigidBody | None = None
                ) -> PlantModel:
    """Build the Pinocchio model; ``base``/``target`` override the robot's base and add the target.

    Parameters
    ----------
    robot : Robot
    base : RigidBody, optional   base truth (defaults to ``robot.base``)
    target : RigidBody, optional target truth in the E frame (no target if None)
    """
    base = base or robot.base
    model = pin.Model()
    model.name = robot.name
    model.gravity = pin.Motion.Zero()  # free-floating in space; orbital dynamics not modelled
    root = pin.JointModelPlanar() if robot.planar else pin.JointModelFreeFlyer()
    parent = model.addJoint(0, root, pin.SE3.Identity(), "base")
    model.appendBodyToJoint(parent, _inertia(base), pin.SE3.Identity())
    model.addBodyFrame("base", parent, pin.SE3.Identity(), 0)
    for link in robot.links:
        placement = pin.SE3(link.R(), np.array(link.xyz, float))
        jm = pin.JointModelRevoluteUnaligned(np.array(link.axis, float))
        parent = model.addJoint(parent, jm, placement, link.name)
        model.appendBodyToJoint(parent, _inertia(link.body), pin.SE3.Identity())
    ee = pin.SE3(robot.ee_R(), np.array(robot.ee_xyz, float))
    ee_frame = model.addFrame(pin.Frame("E", parent, 0, ee, pin.FrameType.OP_FRAME))
    if target is not None:
        model.appendBodyToJoint(parent, _inertia(target), ee)
    nb = 3 if robot.planar else 6
    return PlantModel(model=model, robot=robot, base=base, target=target, planar=robot.planar,
                      nb=nb, n=robot.n_joints, rot_rows=slice(2, 3) if robot.planar else slice(3, 6),
                      ee_frame=ee_frame)


# -- base conventions ---------------------------------------------------------------------------


def quat_to_R(x, y, z, w) -> np.ndarray:
    """DCM (body -> inertial) of a (not necessarily unit) quaternion, normalised on the fly."""
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    xw, yw, zw = x * w, y * w, z * w
    return np.array([[1.0 - s * (yy + zz), s * (xy - zw), s * (xz + yw)],
                     [s * (xy + zw), 1.0 - s * (xx + zz), s * (yz - xw)],
                     [s * (xz - yw), s * (yz + xw), 1.0 - s * (xx + yy)]])


def base_rotation(pm: PlantModel, q: np.ndarray) -> np.ndarray:
    """DCM ``A`` (base -> inertial) from the configuration."""
    if pm.planar:
        c, s = q[2], q[3]
        k = 1.0 / np.hypot(c, s)
        c, s = c * k, s * k
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return quat_to_R(*q[3:7])


def base_generalised_velocity(pm: PlantModel, q, v_S, omega_B) -> np.ndarray:
    """The base part of ``v`` (length ``nb``: local linear velocity and ``omega_B``, planar
    ``(v_x, v_y, omega_z)``) from the inertial velocity ``v_S`` (3,) and ``omega_B`` (3,)."""
    A = base_rotation(pm, q)
    vl = A.T @ np.asarray(v_S, float)
    if pm.planar:
        return np.array([vl[0], vl[1], omega_B[2]])
    return np.concatenate([vl, omega_B])


def initial_configuration(pm: PlantModel, q_arm=None) -> np.ndarray:
    """Base at the inertial origin with identity attitude; arm at ``q_arm`` (default robot.q0)."""
    q_arm = np.asarray(pm.robot.q0 if q_arm is None else q_arm, float)
    head = np.array([0.0, 0.0, 1.0, 0.0]) if pm.planar else np.array([0, 0, 0, 0, 0, 0, 1.0])
    return np.concatenate([head, q_arm])


# -- random models and states (the dynamics tests' cases) ---------------------------------------


def random_inertia(rng) -> pin.Inertia:
    """A physically valid random body: mass, CoM, and a rotated diagonal inertia whose principal
    moments satisfy the triangle inequality."""
    a, b = np.sort(rng.uniform(0.5, 3.0, 2))
    c = rng.uniform(b - a + 0.1, a + b)                    # triangle inequality
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return pin.Inertia(rng.uniform(1.0, 20.0), rng.normal(scale=0.3, size=3),
                       Q @ np.diag([a, b, c]) @ Q.T)


def random_chain(rng, n: int = 7, kinds: str = "uuz") -> pin.Model:
    """Free-flyer base + ``n`` revolute joints with random placements, axes and inertias, built
    in Pinocchio; joint ``k`` is of the kind ``kinds[k % len(kinds)]``: ``x``, ``y``, ``z``
    (``RX``, ``RY``, ``RZ``), ``u`` (unaligned, a random axis) or ``m`` (unaligned along
    ``-z``)."""
    model = pin.Model()
    model.gravity = pin.Motion.Zero()
    parent = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    model.appendBodyToJoint(parent, random_inertia(rng), pin.SE3.Identity())
    aligned = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
    for k in range(n):
        kind = kinds[k % len(kinds)]
        if kind in aligned:
            jm = aligned[kind]()
        elif kind == "m":
            jm = pin.JointModelRevoluteUnaligned(np.array([0.0, 0.0, -1.0]))
        else:
            ax = rng.normal(size=3)
            jm = pin.JointModelRevoluteUnaligned(ax / np.linalg.norm(ax))
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.5, size=3))
        parent = model.addJoint(parent, jm, placement, f"j{k}")
        model.appendBodyToJoint(parent, random_inertia(rng), pin.SE3.Random())
    return model


def random_state(model, rng):
    """A random configuration (base position ~ N(0, 1)), velocity ~ N(0, 1) and generalised
    force ~ N(0, 50) of ``model``."""
    q = pin.randomConfiguration(model, -np.pi * np.ones(model.nq), np.pi * np.ones(model.nq))
    q[:3 if model.joints[1].shortname() == "JointModelFreeFlyer" else 2] = rng.normal(size=3)[
        :3 if model.joints[1].shortname() == "JointModelFreeFlyer" else 2]
    v = rng.normal(size=model.nv)
    tau = rng.normal(scale=50.0, size=model.nv)
    return q, v, tau
