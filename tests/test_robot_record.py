"""The robot record (spacerobot/core/robot_record.py) and its C reader (native/src/arm.c):
every value bit-exact from the Python robot through the text into the C struct; malformed
records refused with a message naming the line and the fault, never a crash, never a read past
the given length; a record written and read under a comma-decimal locale reads the same."""
from __future__ import annotations

import ctypes
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from spacerobot.core import robot_record as rr
from spacerobot.kinematics import ArmGeometry
from spacerobot.robots import URDF_DIR, get_robot, robot_spec

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ["planar", "spatial", "servicer7"]


def robot_of(name):
    return get_robot(name if name != "servicer7" else robot_spec(str(URDF_DIR / "servicer7.urdf")))


def _has(lib, *names):
    try:
        return all(getattr(lib, n) is not None for n in names)
    except AttributeError:
        return False


def core_library(tmp_dir: Path, needed=("sr_robot_parse", "sr_equations")) -> ctypes.CDLL:
    """$SPACEROBOT_CORE_LIB, else the installed library if it has ``needed``, else a fresh
    build of the sources these tests exercise (native/build.py)."""
    from spacerobot import core
    if os.environ.get("SPACEROBOT_CORE_LIB"):
        return core.load_library()
    try:
        lib = core.load_library()
        if _has(lib, *needed):
            return lib
    except core.CoreUnavailable:
        pass
    spec = importlib.util.spec_from_file_location("_sr_native_build", ROOT / "native" / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    return core.load_library(build.build_library(tmp_dir, ["arm.c", "equations.c", "sr_math.c"], strict=True))


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return core_library(tmp_path_factory.mktemp("corelib"))


def bits(a):
    """The IEEE-754 bits of an array (so -0.0 != 0.0 and the comparison is exact)."""
    return np.ascontiguousarray(np.asarray(a, dtype=np.float64)).view(np.uint64)


def assert_bits_equal(got, want, what):
    g, w = bits(got), bits(want)
    assert g.shape == w.shape and np.array_equal(g, w), (what, got, want)


def assert_struct_is_robot(out: rr.SrRobot, robot):
    """Every field of the C struct bit-equal to the robot's values as the estimator's
    ArmGeometry and robot.base hold them; the unused joints zero."""
    g = ArmGeometry(robot)
    a = rr.robot_arrays(out)
    assert a["name"] == robot.name and a["planar"] == robot.planar and a["n"] == robot.n_joints
    assert a["joints"] == [l.name for l in robot.links]
    assert_bits_equal(a["base_mass"], robot.base.mass, "base.mass")
    assert_bits_equal(a["base_com"], robot.base.com, "base.com")
    assert_bits_equal(a["base_I"], robot.base.inertia_matrix(), "base.inertia")
    for key in ("xyz", "R", "axis", "mass", "com", "I", "ee_xyz", "ee_R"):
        assert_bits_equal(a[key], getattr(g, key), key)
    n = robot.n_joints
    tail = [np.ctypeslib.as_array(x)[n:] for x in (out.xyz, out.R, out.axis)]
    assert all(not t.any() for t in tail)
    assert all(out.link[i].m == 0.0 for i in range(n, rr.MAX_JOINTS))


@pytest.mark.parametrize("name", ROBOTS)
def test_record_round_trip_is_bit_exact(lib, tmp_path, name):
    robot = robot_of(name)
    text = rr.robot_record_text(robot)
    assert text.startswith("spacerobot-robot 1\n") and text.endswith("end\n")
    st, out, msg = rr.c_parse_record(text, lib)
    assert st == 0 and msg == "", msg
    assert_struct_is_robot(out, robot)
    # from the file too (fopen "rb"), and with Windows line ends and a byte order mark
    path = rr.write_robot_record(robot, tmp_path / f"{name}.robot")
    st, out2, msg = rr.c_read_record(path, lib)
    assert st == 0, msg
    assert bytes(out2) == bytes(out)
    st, out3, msg = rr.c_parse_record(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode(), lib)
    assert st == 0, msg
    assert bytes(out3) == bytes(out)
    # the Python reader gives the same values
    rec = rr.read_robot_record(path)
    g = ArmGeometry(robot)
    assert rec["n"] == robot.n_joints and rec["planar"] == robot.planar
    assert_bits_equal(rec["base"]["I"], robot.base.inertia_matrix(), "py base.inertia")
    for key, field in (("xyz", "xyz"), ("R", "R"), ("axis", "axis"), ("mass", "mass"),
                       ("com", "com"), ("I", "I")):
        assert_bits_equal([l[field] for l in rec["links"]], getattr(g, key), "py " + key)
    assert_bits_equal(rec["ee_R"], g.ee_R, "py ee_R")
    # the comments carry the decimal values for people
    line = next(l for l in text.splitlines() if l.startswith("link1.mass"))
    assert float(line.split("#")[1]) == robot.links[0].body.mass


def test_struct_layout_matches_the_library(lib):
    lib.sr_robot_size.restype = ctypes.c_size_t
    assert lib.sr_robot_size() == ctypes.sizeof(rr.SrRobot)


def test_names_are_made_record_safe():
    assert rr.record_name("my arm #2\n") == "my_arm__2_"
    assert rr.record_name("") == "_"
    assert len(rr.record_name("x" * 100)) == 63


# -- malformed records ---------------------------------------------------------------------------
def _spatial_text():
    return rr.robot_record_text(robot_of("spatial"))


def _line_no(text, key):
    return next(i for i, l in enumerate(text.splitlines(), 1) if l.split(" ")[0] == key)


def _set_line(text, key, rest):
    lines = [key + " " + rest if l.split(" ")[0] == key else l for l in text.splitlines()]
    assert lines != text.splitlines()
    return "\n".join(lines) + "\n"


def _replace_values(text, key, values):
    return _set_line(text, key, " ".join(rr.hex_double(v) for v in values))


def _drop(text, key):
    return "\n".join(l for l in text.splitlines() if l.split(" ")[0] != key) + "\n"


def _sub(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


T = _spatial_text()
ROT_REFLECT = [1, 0, 0, 0, 1, 0, 0, 0, -1]
CASES = {
    # name: (text, words in the message, line of the fault or None)
    "empty": ("", ["empty"], None),
    "garbage": ("\x00\xff garbage\n", ["not a spacerobot robot record"], 1),
    "version": (_sub(T, "spacerobot-robot 1", "spacerobot-robot 2"), ["version", "2"], 1),
    "missing key": (_drop(T, "base.com"), ["missing key 'base.com'"], None),
    "missing link key": (_drop(T, "link3.axis"), ["missing key 'link3.axis'"], None),
    "no end": (T.replace("end\n", ""), ["without 'end'"], None),
    "after end": (T + "n 3\n", ["after 'end'"], len(T.splitlines()) + 1),
    "n too large": (_sub(T, "\nn 6\n", "\nn 13\n"), ["n out of range"], _line_no(T, "n")),
    "n zero": (_sub(T, "\nn 6\n", "\nn 0\n"), ["n out of range"], _line_no(T, "n")),
    "link beyond n": (_sub(T, "\nn 6\n", "\nn 5\n"), ["link6", "n = 5"], _line_no(T, "link6.joint")),
    "repeated": (T.replace("end\n", "planar 1\nend\n"), ["repeated"], len(T.splitlines())),
    "unknown key": (_sub(T, "\nn 6\n", "\nn 6\nfoo 1\n"), ["unknown key", "foo"], _line_no(T, "n") + 1),
    "bad link index": (_sub(T, "link1.joint", "link13.joint"), ["link number"], _line_no(T, "link1.joint")),
    "decimal number": (_set_line(T, "link2.mass", "1.0"), ["malformed number", "'1.0'"],
                       _line_no(T, "link2.mass")),
    "short hex": (_sub(T, "0x4036b33333333333", "0x4036b3333333333"), ["malformed number"],
                  _line_no(T, "link1.mass")),
    "too few values": (_sub(T, "link1.com 0x0000000000000000 ", "link1.com "),
                       ["expected 3 values", "got 2"], _line_no(T, "link1.com")),
    "not finite": (_sub(T, "0x4036b33333333333", "0x7ff0000000000000"), ["not a finite"],
                   _line_no(T, "link1.mass")),
    "nan": (_sub(T, "0x4036b33333333333", "0x7ff8000000000000"), ["not a finite"],
            _line_no(T, "link1.mass")),
    "negative mass": (_replace_values(T, "link4.mass", [-1.0]), ["mass must be > 0"],
                      _line_no(T, "link4.mass")),
    "axis not unit": (_replace_values(T, "link2.axis", [0.0, 0.0, 1.001]), ["unit"],
                      _line_no(T, "link2.axis")),
    "R reflection": (_replace_values(T, "link3.R", ROT_REFLECT), ["not a rotation"],
                     _line_no(T, "link3.R")),
    "ee.R scaled": (_replace_values(T, "ee.R", [1.01, 0, 0, 0, 1, 0, 0, 0, 1]), ["not a rotation"],
                    _line_no(T, "ee.R")),
    "inertia indefinite": (_replace_values(T, "base.inertia", [1, 0, 0, 0, -1, 0, 0, 0, 1]),
                           ["positive definite"], _line_no(T, "base.inertia")),
    "inertia asymmetric": (_replace_values(T, "link1.inertia", [1, 0.1, 0, 0, 1, 0, 0, 0, 1]),
                           ["symmetric"], _line_no(T, "link1.inertia")),
    "triangle inequality": (_replace_values(T, "link5.inertia", [1, 0, 0, 0, 1, 0, 0, 0, 2.1]),
                            ["triangle"], _line_no(T, "link5.inertia")),
    "planar flag": (_sub(T, "\nplanar 0\n", "\nplanar 2\n"), ["0 or 1"], _line_no(T, "planar")),
    "long name": (_sub(T, "\nname spatial\n", "\nname " + "x" * 64 + "\n"), ["longer than 63"],
                  _line_no(T, "name")),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_record_is_refused_with_its_line(lib, case):
    text, words, line = CASES[case]
    st, out, msg = rr.c_parse_record(text.encode("latin-1"), lib)
    assert st != 0, case
    assert all(w in msg for w in words), (case, msg)
    if line is not None:
        assert f"line {line}:" in msg, (case, msg)
    assert "\n" not in msg and len(msg) < 300
    assert bytes(out) == bytes(ctypes.sizeof(rr.SrRobot)), "the struct is zeroed on error"


def test_triangle_equality_of_a_flat_plate_is_accepted(lib):
    # a thin plate: Izz = Ixx + Iyy exactly (within rounding), as a URDF may well give
    st, _, msg = rr.c_parse_record(_replace_values(T, "link5.inertia",
                                                   [0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.1 + 0.2]), lib)
    assert st == 0, msg


def test_missing_file_and_bad_arguments(lib, tmp_path):
    st, _, msg = rr.c_read_record(tmp_path / "nope.robot", lib)
    assert st != 0 and "cannot open" in msg and "nope.robot" in msg
    err = ctypes.create_string_buffer(8)                   # a short error buffer is cut, not overrun
    out = rr.SrRobot()
    assert lib.sr_robot_parse(b"xx", 2, ctypes.byref(out), err, 8) != 0
    assert len(err.value) == 7
    assert lib.sr_robot_parse(b"xx", 2, ctypes.byref(out), None, 0) != 0
    assert lib.sr_robot_parse(None, 0, ctypes.byref(out), err, 8) != 0
    assert lib.sr_robot_parse(T.encode(), len(T), None, err, 8) != 0


# -- fuzz: never a crash, never a read past len ----------------------------------------------------
def test_every_truncation_is_refused_and_reads_only_len_bytes(lib):
    text = rr.robot_record_text(robot_of("servicer7")).encode()
    # a buffer whose bytes after len would complete the record: a reader that ran past len
    # would accept a truncated record
    buf = ctypes.create_string_buffer(text, len(text))
    out, err = rr.SrRobot(), ctypes.create_string_buffer(256)
    full = len(text) - 1                                    # without the final newline: valid
    for k in range(len(text) + 1):
        st = lib.sr_robot_parse(buf, k, ctypes.byref(out), err, 256)
        if k >= full:
            assert st == 0, (k, err.value)
        else:
            assert st != 0, k                               # every shorter prefix lacks 'end'


def test_random_corruption_never_crashes_and_accepts_only_what_python_reads(lib):
    rng = np.random.default_rng(7)
    base = bytearray(rr.robot_record_text(robot_of("spatial")).encode())
    out, err = rr.SrRobot(), ctypes.create_string_buffer(256)
    accepted = 0
    alphabet = np.frombuffer(b"0123456789abcdefx. \n#\r\t-e", dtype=np.uint8)
    for trial in range(1500):
        b = bytearray(base)
        for _ in range(int(rng.integers(1, 4))):
            pos = int(rng.integers(0, len(b)))
            if rng.random() < 0.5:
                b[pos] = int(rng.integers(0, 256))
            else:
                b[pos] = int(rng.choice(alphabet))
        data = bytes(b)
        st = lib.sr_robot_parse(data, len(data), ctypes.byref(out), err, 256)
        if st == 0:
            # whatever C accepts, the plain Python reader reads to the same values
            accepted += 1
            rec = rr.parse_robot_record(data.decode("latin-1"))
            a = rr.robot_arrays(out)
            assert rec["n"] == a["n"]
            assert_bits_equal([l["R"] for l in rec["links"]], a["R"], "R")
            assert_bits_equal([l["I"] for l in rec["links"]], a["I"], "I")
            assert_bits_equal(rec["ee_xyz"], a["ee_xyz"], "ee_xyz")
        else:
            assert err.value and b"\n" not in err.value
    assert 0 < accepted < 1500          # comments and harmless digits pass, the rest is refused
    # pure garbage, long lines, and a huge number of lines
    for data in (bytes(rng.integers(0, 256, 100_000, dtype=np.uint8)), b"x" * 1_000_000,
                 b"spacerobot-robot 1\n" + b"\n" * 2_000_000, b"spacerobot-robot 1\n" + b"#\n" * 500_000,
                 b"spacerobot-robot 1\n" + b"name a\n" * 1000, b"\x00" * 1000):
        assert lib.sr_robot_parse(data, len(data), ctypes.byref(out), err, 256) != 0


# -- locale --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_record_under_a_comma_decimal_locale(lib, tmp_path):
    """Written and read in a process whose C locale writes 1,5: the same bits."""
    if shutil.which("localedef") is None:
        pytest.skip("localedef not available to make a comma-decimal locale")
    locdir = tmp_path / "locales"
    locdir.mkdir()
    res = subprocess.run(["localedef", "-i", "de_DE", "-f", "UTF-8", str(locdir / "de_DE.UTF-8")],
                         capture_output=True, text=True)
    if not (locdir / "de_DE.UTF-8").exists():
        pytest.skip(f"cannot make the de_DE locale: {res.stderr.strip()}")
    libpath = lib._name
    script = textwrap.dedent(f"""
        import ctypes, locale, sys
        locale.setlocale(locale.LC_ALL, "de_DE.UTF-8")
        libc = ctypes.CDLL(None)
        buf = ctypes.create_string_buffer(32)
        libc.snprintf(buf, 32, b"%g", ctypes.c_double(1.5))
        assert buf.value == b"1,5", buf.value                # the C library's locale is active
        from spacerobot.core import load_library, robot_record as rr
        from spacerobot.robots import get_robot
        lib = load_library({libpath!r})
        rr.write_robot_record(get_robot("spatial"), {str(tmp_path / 'de.robot')!r})
        st, out, msg = rr.c_read_record({str(tmp_path / 'de.robot')!r}, lib)
        assert st == 0, msg
        sys.stdout.write(bytes(out).hex())
    """)
    env = dict(os.environ, LOCPATH=str(locdir), LC_ALL="de_DE.UTF-8")
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                         cwd=str(ROOT))
    assert res.returncode == 0, res.stderr
    here = rr.c_parse_record(rr.robot_record_text(robot_of("spatial")), lib)[1]
    assert bytes.fromhex(res.stdout) == bytes(here)
    assert rr.read_robot_record(tmp_path / "de.robot")["links"][0]["mass"] == 22.7
    assert re.search(r"# 22\.7$", (tmp_path / "de.robot").read_text(), re.M)
