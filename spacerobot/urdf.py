"""Read a URDF into the project's robot record (:class:`spacerobot.robots.Robot`).

Standard library (``xml.etree``), numpy and the native core's body check
(:func:`spacerobot.robots.check_body`), no Pinocchio, so that it works wherever the estimator
does. What a URDF must describe:

* a tree with one root link, the **base** (floating in space; its frame origin is the base
  sensor point S and its ``<inertial>`` the base truth);
* from it a **serial chain** of ``revolute`` or ``continuous`` joints (1 to 12); ``fixed``
  joints anywhere merge their child link into the parent (frames composed, masses added by
  the parallel-axis theorem); every other joint type is refused;
* the **end effector**: the link named by ``ee`` (grasp point E = its frame origin, target
  frame T = its frame); by default the last link of the chain, which may hang on fixed joints.
  No movable joint may follow it.

Conversion into the record's conventions (see :mod:`spacerobot.robots`):

* joint ``<origin xyz rpy>`` -> :class:`~spacerobot.robots.ArmLink` ``xyz`` and ``rotation``
  (``R = Rz(yaw) Ry(pitch) Rx(roll)``, the placement of the joint (child link) frame in the
  parent frame), composed with the fixed joints before it; ``<axis>`` -> ``axis`` (unit);
* ``<inertial>``: the URDF gives the mass, the CoM frame (``<origin>``) in the link frame and
  the inertia about the CoM in that CoM frame; the record stores the CoM offset ``b`` and the
  CoM inertia ``R_c I R_c^T`` in the link (joint) frame;
* ``<limit lower upper>`` of a revolute joint -> ``ArmLink.limits``; the home posture ``q0`` is
  the middle of the limits (0 for a continuous joint).

The robot is **planar** (8 identified parameters; motion in the base x-y plane) when every
joint axis is parallel to the base z axis at q = 0, unless ``motion`` forces one or the other.

Every refusal is a :class:`URDFError` (a ``ValueError``) whose message names the file and the
element.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

from .robots import ArmLink, RigidBody, Robot, check_body, inertia_matrix

#: joint types that move (revolute about an axis); ``fixed`` merges; the rest are refused
MOVABLE = ("revolute", "continuous")
MAX_JOINTS = 12
MOTIONS = ("auto", "planar", "spatial")
#: tolerance of "parallel to the base z axis" (sine of the angle)
PARALLEL_TOL = 1e-9


class URDFError(ValueError):
    """A URDF the project cannot use; the message names the file and the element."""


def rpy_matrix(rpy) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (3, 3)."""
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), \
        math.sin(y)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return Rz @ Ry @ Rx


#: the rotation of a frame that has not been turned (identity by construction; never written to)
_IDENTITY_MARK = np.eye(3)
_IDENTITY_MARK.setflags(write=False)


class _Frame:
    """A rigid transform ``x_parent = R x_child + p`` (child frame placed in the parent)."""

    def __init__(self, R: np.ndarray | None = None, p: np.ndarray | None = None):
        self.R = _IDENTITY_MARK if R is None else R
        self.p = np.zeros(3) if p is None else p

    def then(self, other: "_Frame") -> "_Frame":
        """This placement followed by ``other`` (``other`` given in this child frame)."""
        return _Frame(self.R @ other.R, self.p + self.R @ other.p)


class _Reader:
    """Parse one URDF document; ``where`` prefixes every error message."""

    def __init__(self, root: ET.Element, where: str):
        self.where = where
        if root.tag != "robot":
            self.fail(f"the root element is <{root.tag}>, expected <robot>")
        self.name = root.get("name") or "robot"
        self.links: Dict[str, ET.Element] = {}
        for el in root.findall("link"):
            name = el.get("name")
            if not name:
                self.fail("a <link> has no name attribute")
            if name in self.links:
                self.fail(f"link {name!r} is defined twice")
            self.links[name] = el
        if not self.links:
            self.fail("no <link> element")
        self.joints = [self._joint(el) for el in root.findall("joint")]

    def fail(self, msg: str):
        raise URDFError(f"{self.where}: {msg}")

    # -- elements ------------------------------------------------------------------------------
    def floats(self, el: ET.Element, attr: str, n: int, what: str, default=None) -> np.ndarray:
        text = el.get(attr)
        if text is None:
            if default is None:
                self.fail(f"{what}: missing attribute {attr!r}")
            return np.array(default, float)
        try:
            vals = np.array([float(t) for t in text.split()], float)
        except ValueError:
            vals = np.array([])
        if vals.shape != (n,) or not np.all(np.isfinite(vals)):
            self.fail(f"{what}: {attr}={text!r} is not {n} finite number(s)")
        return vals

    def origin(self, el: ET.Element, what: str) -> _Frame:
        """The ``<origin xyz rpy>`` child of ``el`` (identity if absent)."""
        o = el.find("origin")
        if o is None:
            return _Frame()
        xyz = self.floats(o, "xyz", 3, f"{what} <origin>", (0.0, 0.0, 0.0))
        rpy = self.floats(o, "rpy", 3, f"{what} <origin>", (0.0, 0.0, 0.0))
        return _Frame(rpy_matrix(rpy) if np.any(rpy) else _IDENTITY_MARK, xyz)

    def _joint(self, el: ET.Element) -> dict:
        name = el.get("name") or "?"
        what = f"joint {name!r}"
        jtype = el.get("type")
        if jtype not in MOVABLE + ("fixed",):
            self.fail(f"{what} has type {jtype!r}: unsupported (use revolute, continuous or "
                      f"fixed; the base floats by itself, no joint to a world link)")
        ends = {}
        for tag in ("parent", "child"):
            e = el.find(tag)
            link = e.get("link") if e is not None else None
            if link is None:
                self.fail(f"{what} has no <{tag} link=...>")
            if link not in self.links:
                self.fail(f"{what}: <{tag} link={link!r}> names no <link>")
            ends[tag] = link
        j = dict(name=name, type=jtype, parent=ends["parent"], child=ends["child"],
                 frame=self.origin(el, what), limits=None)
        if jtype in MOVABLE:
            ax = el.find("axis")
            axis = (self.floats(ax, "xyz", 3, f"{what} <axis>") if ax is not None
                    else np.array([1.0, 0.0, 0.0]))       # the URDF default
            norm = np.linalg.norm(axis)
            if not norm > 0.0:
                self.fail(f"{what} <axis xyz> is the zero vector")
            j["axis"] = axis / norm if norm != 1.0 else axis
            lim = el.find("limit")
            if jtype == "revolute" and lim is not None and lim.get("lower") is not None \
                    and lim.get("upper") is not None:
                lo = float(self.floats(lim, "lower", 1, f"{what} <limit>")[0])
                hi = float(self.floats(lim, "upper", 1, f"{what} <limit>")[0])
                if not lo <= hi:
                    self.fail(f"{what} <limit>: lower {lo} > upper {hi}")
                j["limits"] = (lo, hi)
        return j

    @property
    def root_link(self) -> Optional[str]:
        """The link that is no joint's child (None if there is not exactly one)."""
        children = {j["child"] for j in self.joints}
        roots = [n for n in self.links if n not in children]
        return roots[0] if len(roots) == 1 else None

    def _fixed_child(self, link: str) -> Optional[str]:
        """The child of a fixed joint hanging on ``link`` (None if there is none)."""
        return next((j["child"] for j in self.joints
                     if j["parent"] == link and j["type"] == "fixed"), None)

    def inertial(self, link: str, required: bool) -> Optional[RigidBody]:
        """The link's ``<inertial>`` as a body in the link frame (None if absent and allowed,
        or massless on a fixed joint)."""
        what = f"link {link!r}"
        el = self.links[link].find("inertial")
        if el is None:
            if required and link == self.root_link and self._fixed_child(link):
                self.fail(f"{what} is the root link, has no <inertial> and is fixed to "
                          f"{self._fixed_child(link)!r}: a link fixed to a 'world' cannot "
                          f"float; remove it and its joint (the base floats by itself, no "
                          f"joint to a world link)")
            if required:
                self.fail(f"{what} has no <inertial> (mass, CoM and inertia are needed for "
                          f"the base and for every link a joint moves)")
            return None
        m_el, i_el = el.find("mass"), el.find("inertia")
        if m_el is None or i_el is None:
            self.fail(f"{what} <inertial> needs <mass value> and <inertia ixx ... izz>")
        mass = float(self.floats(m_el, "value", 1, f"{what} <inertial><mass>")[0])
        I6 = [float(self.floats(i_el, k, 1, f"{what} <inertial><inertia>")[0])
              for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")]
        frame = self.origin(el, f"{what} <inertial>")
        if not required and mass == 0.0 and not any(I6):
            return None                              # a frame-only link on a fixed joint
        try:
            check_body(f"{self.where}: {what} <inertial>", mass, frame.p, I6)
        except ValueError as e:
            raise URDFError(str(e)) from None
        I = inertia_matrix(I6)
        return _body(mass, frame.p, I if frame.R is _IDENTITY_MARK else frame.R @ I @ frame.R.T)

    # -- the chain -----------------------------------------------------------------------------
    def chain(self) -> Tuple[str, List[dict]]:
        """``(root link, joints from the root to the tip)``; refuses loops and branches."""
        parent_of: Dict[str, dict] = {}
        children: Dict[str, List[dict]] = {n: [] for n in self.links}
        for j in self.joints:
            if j["child"] in parent_of:
                self.fail(f"closed chain: link {j['child']!r} is the child of joints "
                          f"{parent_of[j['child']]['name']!r} and {j['name']!r}")
            parent_of[j["child"]] = j
            children[j["parent"]].append(j)
        roots = [n for n in self.links if n not in parent_of]
        if not roots:
            self.fail("closed chain: every link is the child of a joint (a loop; the base "
                      "link must be the child of none)")
        if len(roots) > 1:
            self.fail(f"links {roots} are each the child of no joint: one base link expected "
                      f"(the robot must be one connected chain)")
        path, link, seen = [], roots[0], {roots[0]}
        while children[link]:
            if len(children[link]) > 1:
                self.fail(f"branching chain: link {link!r} is the parent of joints "
                          f"{[j['name'] for j in children[link]]}; only a serial chain is "
                          f"supported")
            j = children[link][0]
            path.append(j)
            link = j["child"]
            seen.add(link)
        lost = [n for n in self.links if n not in seen]
        if lost:
            self.fail(f"closed chain: links {lost} are not reachable from the base link "
                      f"{roots[0]!r} (they form a loop)")
        return roots[0], path



def _body(mass: float, com, I: np.ndarray) -> RigidBody:
    return RigidBody(float(mass), tuple(float(c) for c in com),
                     tuple(float(x) for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2],
                                              I[1, 2])))


def _moved(body: RigidBody, f: _Frame) -> Tuple[float, np.ndarray, np.ndarray]:
    """``(m, CoM, CoM inertia)`` of ``body`` (given in frame ``f``'s child) in ``f``'s parent."""
    I = body.inertia_matrix()
    return body.mass, f.p + f.R @ np.array(body.com), f.R @ I @ f.R.T


def merge_bodies(parts: List[Tuple[RigidBody, _Frame]]) -> RigidBody:
    """One rigid body from parts placed by frames: masses add, the CoM is the mass-weighted
    mean, inertias move to it by the parallel-axis theorem
    ``I_c = sum R_i I_i R_i^T + m_i (|d_i|^2 E - d_i d_i^T)``, ``d_i = c_i - c``."""
    if len(parts) == 1 and parts[0][1].R is _IDENTITY_MARK and not np.any(parts[0][1].p):
        return parts[0][0]                        # nothing to move: keep the numbers exact
    moved = [_moved(b, f) for b, f in parts]
    m = sum(p[0] for p in moved)
    c = sum(p[0] * p[1] for p in moved) / m
    I = np.zeros((3, 3))
    for mi, ci, Ii in moved:
        d = ci - c
        I += Ii + mi * (d @ d * np.eye(3) - np.outer(d, d))
    return _body(m, c, I)


class _Assembler:
    """Walks the chain from the base link and collects the record's bodies.

    ``parts`` are the rigid parts of the body being collected, each placed in that body's
    frame; ``here`` is the frame of the current link in the body's frame (fixed joints move
    it); ``R_base`` the current link's orientation in the base frame at q = 0.
    """

    def __init__(self, rd: _Reader, base_link: str):
        self.rd = rd
        self.here = _Frame()
        self.parts: List[Tuple[RigidBody, _Frame]] = [(rd.inertial(base_link, True), self.here)]
        self.joint: Optional[dict] = None          # the movable joint of the body collected
        self.base: Optional[RigidBody] = None
        self.links: List[ArmLink] = []
        self.R_base = np.eye(3)
        self.axes_base: List[Tuple[str, np.ndarray]] = []   # joint axes in the base frame

    def fixed(self, j: dict) -> None:
        """Merge the child link of fixed joint ``j`` into the current body."""
        self.here = self.here.then(j["frame"])
        self.R_base = self.R_base @ j["frame"].R
        body = self.rd.inertial(j["child"], required=False)
        if body is not None:
            self.parts.append((body, self.here))

    def movable(self, j: dict) -> None:
        """Close the current body; the child link of ``j`` starts the next one."""
        self.close()
        self.R_base = self.R_base @ j["frame"].R
        self.axes_base.append((j["name"], self.R_base @ j["axis"]))
        self.joint = dict(j, place=self.here.then(j["frame"]))
        self.here = _Frame()
        self.parts = [(self.rd.inertial(j["child"], required=True), self.here)]

    def close(self) -> None:
        """The collected parts become the base or the link of the current joint."""
        body = merge_bodies(self.parts)
        j = self.joint
        if j is None:
            self.base = body
            return
        self.links.append(ArmLink(j["name"], tuple(float(x) for x in j["place"].p),
                                  tuple(float(x) for x in j["place"].R.reshape(9)),
                                  tuple(float(x) for x in j["axis"]), body, j["limits"]))

    def planar_axes(self) -> List[str]:
        """Names of the joints whose axis is NOT parallel to the base z axis."""
        return [n for n, a in self.axes_base
                if np.linalg.norm(a[:2]) > PARALLEL_TOL * np.linalg.norm(a)]


def parse_robot(text: str | bytes, ee: Optional[str] = None, motion: str = "auto",
                where: str = "URDF") -> Robot:
    """The robot record of a URDF document (see the module docstring).

    Parameters
    ----------
    text : str or bytes   the URDF (XML)
    ee : str, optional    end-effector link (default: the last link of the chain)
    motion : {'auto', 'planar', 'spatial'}
        planar model if all joint axes are parallel to the base z axis ('auto'), or forced
    where : str           the file name used in error messages

    Raises
    ------
    URDFError
    """
    if motion not in MOTIONS:
        raise URDFError(f"{where}: motion must be one of {MOTIONS}, got {motion!r}")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise URDFError(f"{where}: not well-formed XML: {e}") from None
    rd = _Reader(root, where)
    base_link, path = rd.chain()
    if ee is not None and ee not in rd.links:
        rd.fail(f"end-effector link {ee!r} not found (links: {sorted(rd.links)})")
    n_movable = sum(j["type"] in MOVABLE for j in path)
    if not 1 <= n_movable <= MAX_JOINTS:
        rd.fail(f"the chain has {n_movable} revolute joints; 1 to {MAX_JOINTS} are supported")

    asm, ee_frame = _Assembler(rd, base_link), None
    for link, j in zip([base_link] + [j["child"] for j in path], path + [None]):
        if link == ee:
            ee_frame = asm.here
        if j is None:
            break
        if j["type"] == "fixed":
            asm.fixed(j)
        elif ee_frame is not None:
            rd.fail(f"end-effector link {ee!r} is not at the tip: joint {j['name']!r} "
                    f"moves after it")
        else:
            asm.movable(j)
    asm.close()
    ee_frame = ee_frame or asm.here               # default: the last link of the chain

    not_parallel = asm.planar_axes()
    if motion == "planar" and not_parallel:
        rd.fail(f"planar motion forced, but the axes of joints {not_parallel} are not "
                f"parallel to the base z axis")
    planar = not not_parallel if motion == "auto" else motion == "planar"
    links = asm.links
    q0 = tuple(0.5 * (l.limits[0] + l.limits[1]) if l.limits else 0.0 for l in links)
    return Robot(name=rd.name, planar=planar, base=asm.base, links=tuple(links),
                 ee_xyz=tuple(float(x) for x in ee_frame.p),
                 ee_rotation=tuple(float(x) for x in ee_frame.R.reshape(9)), q0=q0,
                 description=f"{rd.name} ({Path(where).name}): {asm.base.mass:g} kg base, "
                             f"{len(links)}-joint {'planar' if planar else 'spatial'} arm, "
                             f"{sum(l.body.mass for l in links):g} kg, end effector "
                             f"{ee or (path[-1]['child'])!r}")


def load_robot(path: str | Path, ee: Optional[str] = None, motion: str = "auto") -> Robot:
    """The robot record of the URDF file ``path`` (:func:`parse_robot`)."""
    path = Path(path)
    try:
        text = path.read_bytes()
    except OSError as e:
        raise URDFError(f"{path}: cannot read the URDF: {e.strerror or e}") from None
    return parse_robot(text, ee=ee, motion=motion, where=str(path))
