"""The compiled rigid-body dynamics (spacerobot/plant/rigid_body.py) against Pinocchio: forward
dynamics (ABA), joint-space inertia (CRBA), non-linear effects and centroidal momentum at random
states, for the planar and spatial robots and the shipped 7-joint servicer URDF (each with a
grasped target), a randomly generated 7-joint chain and an 8-joint one with joints about x, y,
z, -z and random axes, so that arbitrary serial chains are covered."""
import numpy as np
import pinocchio as pin
import pytest

from spacerobot.plant import rigid_body as rb
from spacerobot.plant.dynamics import build_model
from spacerobot.robots import ROBOTS, URDF_DIR, RigidBody, get_robot

TOL = 1e-12
TARGET = RigidBody(120.0, (0.05, 0.02, -0.03), (9.0, 7.0, 5.0, 0.3, -0.2, 0.1))


def _random_inertia(rng) -> pin.Inertia:
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
    model.appendBodyToJoint(parent, _random_inertia(rng), pin.SE3.Identity())
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
        model.appendBodyToJoint(parent, _random_inertia(rng), pin.SE3.Random())
    return model


def _models():
    out = {name: build_model(robot, target=TARGET).model for name, robot in ROBOTS.items()}
    out["servicer7"] = build_model(get_robot(str(URDF_DIR / "servicer7.urdf")),
                                   target=TARGET).model
    out["chain7"] = random_chain(np.random.default_rng(7))
    # every kind of joint frame of chain_arrays (identity, the x/y permutations, general)
    out["chain_xyzm"] = random_chain(np.random.default_rng(8), n=8, kinds="xyzmu")
    return out


MODELS = _models()


def _random_state(model, rng):
    q = pin.randomConfiguration(model, -np.pi * np.ones(model.nq), np.pi * np.ones(model.nq))
    q[:3 if model.joints[1].shortname() == "JointModelFreeFlyer" else 2] = rng.normal(size=3)[
        :3 if model.joints[1].shortname() == "JointModelFreeFlyer" else 2]
    v = rng.normal(size=model.nv)
    tau = rng.normal(scale=50.0, size=model.nv)
    return q, v, tau


@pytest.mark.parametrize("name", list(MODELS))
def test_compiled_dynamics_equal_pinocchio(name):
    model = MODELS[name]
    data = model.createData()
    planar, R, p, I6, mc = rb.chain_arrays(model)
    assert planar == (name == "planar")
    ws = rb.Workspace(R.shape[0] - 1).arrays()
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    nv = model.nv
    for _ in range(20):
        q, v, tau = _random_state(model, rng)
        # forward dynamics
        ddq = np.empty(nv)
        assert rb.aba(planar, R, p, I6, q, v, tau, ddq, *ws) == 0
        ref = pin.aba(model, data, q, v, tau)
        assert np.max(np.abs(ddq - ref)) <= TOL * max(1.0, np.max(np.abs(ref)))
        # M, nle, centroidal momentum, centre of mass
        M, nle, hg = np.empty((nv, nv)), np.empty(nv), np.empty(6)
        com = np.array(rb.terms(planar, R, p, I6, mc, q, v, M, nle, hg, *ws))
        pin.computeAllTerms(model, data, q, v)
        Mref = data.M.copy()
        Mref = np.triu(Mref) + np.triu(Mref, 1).T
        assert np.max(np.abs(M - Mref)) <= TOL * np.max(np.abs(Mref))
        assert np.max(np.abs(nle - data.nle)) <= TOL * max(1.0, np.max(np.abs(data.nle)))
        assert np.max(np.abs(hg - data.hg.vector)) <= TOL * max(1.0, np.max(np.abs(data.hg.vector)))
        assert np.max(np.abs(com - data.com[0])) <= TOL * max(1.0, np.max(np.abs(data.com[0])))
        # the forward dynamics inverts M ddq + nle = tau (independent of Pinocchio's ABA)
        assert np.max(np.abs(M @ ddq + nle - tau)) <= 1e-10 * max(1.0, np.max(np.abs(tau)))


def test_chain_arrays_reject_other_models():
    model = pin.Model()
    model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "j")
    with pytest.raises(ValueError, match="root joint"):
        rb.chain_arrays(model)
    model = random_chain(np.random.default_rng(1), 2)
    model.gravity = pin.Motion(np.array([0, 0, -9.81, 0, 0, 0]))
    with pytest.raises(ValueError, match="gravity"):
        rb.chain_arrays(model)
    model = pin.Model()
    model.gravity = pin.Motion.Zero()
    parent = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    model.addJoint(parent, pin.JointModelPZ(), pin.SE3.Identity(), "slider")
    with pytest.raises(ValueError, match="revolute"):
        rb.chain_arrays(model)
