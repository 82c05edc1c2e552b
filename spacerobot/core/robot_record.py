"""The robot record: a robot as a small text file that the C core reads (``native/src/arm.h``).

The FMUs carry the record in ``resources/`` and read it at instantiation, so that building the
FMUs of a new robot (``spacerobot build --robot X.urdf``) needs no compiler and one binary
serves every robot. The record describes the whole robot: the base body, every link (joint
placement and orientation in the parent frame, unit joint axis, the link body), the
end-effector frame E and the planar flag.

Format (version 1, line-oriented, ``#`` starts a comment)::

    spacerobot-robot 1
    name planar
    planar 1
    n 3
    base.mass 0x407f400000000000  # 500.0
    ...
    link1.joint joint1
    link1.xyz 0x3fe0000000000000 0x0000000000000000 0x0000000000000000  # 0.5 0.0 0.0
    ...
    end

Every double is its IEEE-754 bit pattern in hex (``0x`` + 16 digits): the C reader gets the
exact value with integer parsing only, whatever the host's locale; the decimal value beside it
is for people and is not read. The values are those of :class:`spacerobot.kinematics.ArmGeometry`
(the estimator's arrays: the axis normalised as there) and of ``robot.base``, so the C
equations reproduce the Python ones.
"""
from __future__ import annotations

import ctypes
import os
import re
import struct
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from ..kinematics import ArmGeometry
from ..robots import Robot

MAGIC = "spacerobot-robot"
VERSION = 1
#: most movable joints a record (and the C core, ``SR_MAX_JOINTS``) allows
MAX_JOINTS = 12
#: longest name in the record (``SR_NAME_MAX``)
NAME_MAX = 63

_NAME_BAD = re.compile(r"[^\x21-\x7e]|#")


def record_name(name: str) -> str:
    """``name`` as the record stores it: printable ASCII without blanks or '#' (others become
    '_'), at most 63 characters, never empty."""
    s = _NAME_BAD.sub("_", str(name))[:NAME_MAX]
    return s or "_"


def hex_double(x: float) -> str:
    """``0x`` + the 16 hex digits of the IEEE-754 bits of ``x`` (big-endian order)."""
    return "0x" + struct.pack(">d", float(x)).hex()


def double_of_hex(s: str) -> float:
    """Inverse of :func:`hex_double`; ``ValueError`` unless ``0x`` + 16 hex digits."""
    if len(s) != 18 or s[:2] not in ("0x", "0X") or not re.fullmatch(r"[0-9a-fA-F]{16}", s[2:]):
        raise ValueError(f"malformed number {s!r} (expected 0x and 16 hex digits)")
    return struct.unpack(">d", bytes.fromhex(s[2:]))[0]


def _line(key: str, values) -> str:
    vals = [float(v) for v in np.asarray(values, dtype=float).ravel()]
    return (f"{key} {' '.join(hex_double(v) for v in vals)}  # "
            f"{' '.join(repr(v) for v in vals)}")


def robot_record_text(robot: Robot) -> str:
    """The record of ``robot`` (see the module docstring) as text."""
    geom = ArmGeometry(robot)
    n = geom.n
    if not 1 <= n <= MAX_JOINTS:
        raise ValueError(f"robot {robot.name!r} has {n} movable joints; the record allows 1 to "
                         f"{MAX_JOINTS}")
    out = [
        f"{MAGIC} {VERSION}",
        "# spacerobot robot record (read by native/src/arm.c, written by",
        "# spacerobot/core/robot_record.py). Every number is the IEEE-754 bit pattern of a double",
        "# in hex: exact and locale-independent; the decimal value after '#' is for people only.",
        "# Frames: joint K is placed at xyz with orientation R (3x3 row-major) in its parent's",
        "# frame (the base frame B for K = 1, else link K-1), axis is unit in the joint frame;",
        "# bodies: mass [kg], com [m] and inertia about the com [kg.m2] (3x3) in their own frame;",
        "# ee: the end-effector frame E in the last link's frame.",
        f"name {record_name(robot.name)}",
        f"planar {1 if robot.planar else 0}",
        f"n {n}",
        _line("base.mass", [robot.base.mass]),
        _line("base.com", robot.base.com),
        _line("base.inertia", robot.base.inertia_matrix()),
    ]
    for i, link in enumerate(robot.links):
        k = f"link{i + 1}"
        out += [
            f"{k}.joint {record_name(link.name)}",
            _line(f"{k}.xyz", geom.xyz[i]),
            _line(f"{k}.R", geom.R[i]),
            _line(f"{k}.axis", geom.axis[i]),
            _line(f"{k}.mass", [geom.mass[i]]),
            _line(f"{k}.com", geom.com[i]),
            _line(f"{k}.inertia", geom.I[i]),
        ]
    out += [_line("ee.xyz", geom.ee_xyz), _line("ee.R", geom.ee_R), "end"]
    return "\n".join(out) + "\n"


def write_robot_record(robot: Robot, path: os.PathLike) -> Path:
    """Write the record of ``robot`` to ``path`` (UTF-8, ``\\n`` line ends); returns the path."""
    p = Path(path)
    p.write_bytes(robot_record_text(robot).encode("ascii"))
    return p


#: the blanks between tokens (as the C reader: lines end at '\n' only)
_BLANKS = re.compile(r"[ \t\r\v\f]+")
_SIZES = {"mass": 1, "com": 3, "inertia": 9, "xyz": 3, "R": 9, "axis": 3}


def parse_robot_record(text: str) -> dict:
    """The values of a record as a dict (a plain reader for tests and tools; the C reader is
    the one that validates physically):

    ``{"version", "name", "planar" (bool), "n", "base": {"mass", "com" (3,), "I" (3, 3)},
    "links": [{"joint", "xyz", "R" (3, 3), "axis", "mass", "com", "I" (3, 3)}] * n,
    "ee_xyz" (3,), "ee_R" (3, 3)}``. ``ValueError`` names the line of a malformed record.
    """
    keys: dict = {}
    header = done = False
    for no, raw in enumerate(text.removeprefix("\ufeff").split("\n"), 1):
        toks = [t for t in _BLANKS.split(raw.split("#", 1)[0]) if t]
        if not toks:
            continue
        if done:
            raise ValueError(f"robot record line {no}: content after 'end'")
        if not header:
            if toks != [MAGIC, str(VERSION)]:
                raise ValueError(f"robot record line {no}: expected '{MAGIC} {VERSION}'")
            header = True
            continue
        if toks[0] == "end":
            done = True
            continue
        if toks[0] in keys:
            raise ValueError(f"robot record line {no}: key {toks[0]!r} repeated")
        field = toks[0].rsplit(".", 1)[-1]
        if toks[0] in ("name", "planar", "n") or field == "joint":
            if len(toks) != 2:
                raise ValueError(f"robot record line {no}: {toks[0]}: expected one value")
            keys[toks[0]] = toks[1]
        elif field in _SIZES:
            if len(toks) - 1 != _SIZES[field]:
                raise ValueError(f"robot record line {no}: {toks[0]}: expected "
                                 f"{_SIZES[field]} values")
            try:
                keys[toks[0]] = np.array([double_of_hex(t) for t in toks[1:]])
            except ValueError as e:
                raise ValueError(f"robot record line {no}: {toks[0]}: {e}") from None
        else:
            raise ValueError(f"robot record line {no}: unknown key {toks[0]!r}")
    if not done:
        raise ValueError("robot record: no 'end' line (truncated?)")

    def get(key):
        if key not in keys:
            raise ValueError(f"robot record: missing key {key!r}")
        return keys.pop(key)

    def body(prefix):
        return {"mass": float(get(f"{prefix}.mass")[0]), "com": get(f"{prefix}.com"),
                "I": get(f"{prefix}.inertia").reshape(3, 3)}

    n = int(get("n"))
    if not 1 <= n <= MAX_JOINTS:
        raise ValueError(f"robot record: n = {n} out of 1..{MAX_JOINTS}")
    rec = {"version": VERSION, "name": get("name"), "planar": get("planar") == "1", "n": n,
           "base": body("base"), "links": []}
    for i in range(1, n + 1):
        k = f"link{i}"
        rec["links"].append({"joint": get(f"{k}.joint"), "xyz": get(f"{k}.xyz"),
                             "R": get(f"{k}.R").reshape(3, 3), "axis": get(f"{k}.axis"),
                             **body(k)})
    rec["ee_xyz"] = get("ee.xyz")
    rec["ee_R"] = get("ee.R").reshape(3, 3)
    if keys:
        raise ValueError(f"robot record: keys beyond the robot's n = {n}: {sorted(keys)}")
    return rec


def read_robot_record(path: os.PathLike) -> dict:
    """:func:`parse_robot_record` of the file at ``path``."""
    return parse_robot_record(Path(path).read_bytes().decode("utf-8"))


# -- the C view ---------------------------------------------------------------------------------
class SrBody(ctypes.Structure):
    """``sr_body`` (native/src/arm.h)."""

    _fields_ = [("m", ctypes.c_double), ("com", ctypes.c_double * 3),
                ("I", ctypes.c_double * 9)]


class SrRobot(ctypes.Structure):
    """``sr_robot`` (native/src/arm.h): a plain struct, no pointers."""

    _fields_ = [
        ("name", ctypes.c_char * (NAME_MAX + 1)),
        ("planar", ctypes.c_int),
        ("n", ctypes.c_int),
        ("base", SrBody),
        ("xyz", (ctypes.c_double * 3) * MAX_JOINTS),
        ("R", (ctypes.c_double * 9) * MAX_JOINTS),
        ("axis", (ctypes.c_double * 3) * MAX_JOINTS),
        ("link", SrBody * MAX_JOINTS),
        ("ee_xyz", ctypes.c_double * 3),
        ("ee_R", ctypes.c_double * 9),
        ("joint", (ctypes.c_char * (NAME_MAX + 1)) * MAX_JOINTS),
    ]


def _bind(lib: ctypes.CDLL) -> ctypes.CDLL:
    if getattr(lib, "_sr_robot_bound", False):
        return lib
    lib.sr_robot_parse.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(SrRobot),
                                   ctypes.c_char_p, ctypes.c_size_t]
    lib.sr_robot_parse.restype = ctypes.c_int
    lib.sr_robot_read.argtypes = [ctypes.c_char_p, ctypes.POINTER(SrRobot), ctypes.c_char_p,
                                  ctypes.c_size_t]
    lib.sr_robot_read.restype = ctypes.c_int
    lib.sr_robot_size.argtypes = []
    lib.sr_robot_size.restype = ctypes.c_size_t
    if lib.sr_robot_size() != ctypes.sizeof(SrRobot):
        raise RuntimeError(f"sr_robot is {lib.sr_robot_size()} bytes in the library, "
                           f"{ctypes.sizeof(SrRobot)} in spacerobot.core.robot_record.SrRobot")
    lib._sr_robot_bound = True
    return lib


def _library(lib: Optional[ctypes.CDLL]) -> ctypes.CDLL:
    if lib is None:
        from . import lib as default_lib
        lib = default_lib()
    return _bind(lib)


def c_parse_record(data: bytes | str, lib: Optional[ctypes.CDLL] = None):
    """``(status, SrRobot, message)`` of the C reader ``sr_robot_parse`` on ``data``."""
    L = _library(lib)
    if isinstance(data, str):
        data = data.encode("utf-8")
    out, err = SrRobot(), ctypes.create_string_buffer(512)
    st = L.sr_robot_parse(data, len(data), ctypes.byref(out), err, len(err))
    return st, out, err.value.decode("ascii", "replace")


def c_read_record(path: os.PathLike, lib: Optional[ctypes.CDLL] = None):
    """``(status, SrRobot, message)`` of the C reader ``sr_robot_read`` on the file ``path``."""
    L = _library(lib)
    out, err = SrRobot(), ctypes.create_string_buffer(512)
    st = L.sr_robot_read(os.fsencode(path), ctypes.byref(out), err, len(err))
    return st, out, err.value.decode("ascii", "replace")


def c_robot(robot: Robot, lib: Optional[ctypes.CDLL] = None) -> SrRobot:
    """The ``sr_robot`` of ``robot`` through its record and the C reader (``ValueError`` with
    the reader's message if it refuses)."""
    st, out, msg = c_parse_record(robot_record_text(robot), lib)
    if st != 0:
        raise ValueError(msg)
    return out


def robot_arrays(r: SrRobot) -> dict:
    """The fields of an ``SrRobot`` as NumPy arrays (copies), keyed as :class:`ArmGeometry`
    (``xyz, R, axis, mass, com, I, ee_xyz, ee_R`` over the n links) plus ``name, planar, n,
    joints, base_mass, base_com, base_I``."""
    n = r.n
    arr = lambda x, shape: np.array(np.ctypeslib.as_array(x), dtype=float).reshape(shape)  # noqa: E731
    return {
        "name": r.name.decode("ascii"), "planar": bool(r.planar), "n": n,
        "joints": [r.joint[i].value.decode("ascii") for i in range(n)],
        "base_mass": r.base.m, "base_com": arr(r.base.com, 3), "base_I": arr(r.base.I, (3, 3)),
        "xyz": arr(r.xyz, (MAX_JOINTS, 3))[:n], "R": arr(r.R, (MAX_JOINTS, 3, 3))[:n],
        "axis": arr(r.axis, (MAX_JOINTS, 3))[:n],
        "mass": np.array([r.link[i].m for i in range(n)]),
        "com": np.array([list(r.link[i].com) for i in range(n)]).reshape(n, 3),
        "I": np.array([list(r.link[i].I) for i in range(n)]).reshape(n, 3, 3),
        "ee_xyz": arr(r.ee_xyz, 3), "ee_R": arr(r.ee_R, (3, 3)),
    }


__all__: Sequence[str] = (
    "MAGIC", "VERSION", "MAX_JOINTS", "record_name", "hex_double", "double_of_hex",
    "robot_record_text", "write_robot_record", "parse_robot_record", "read_robot_record",
    "SrBody", "SrRobot", "c_parse_record", "c_read_record", "c_robot", "robot_arrays",
)
