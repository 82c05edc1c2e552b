"""The native core's number formatting (native/src/sr_text.c), which every message of the core,
the FMI layer and the glue goes through: against Python's own formatting, in a host that set a
German locale, and on Windows.

A C program built from sr_text.c alone reads IEEE-754 bit patterns and prints, for each value,
``sr_text_num`` with 1 to 17 significant digits, ``sr_text_repr`` and ``sr_text_format`` of
``"%g %.3g %.17g %d %u %lld %s %%"``. Over 20 000 values (random bit patterns, powers of ten
from 1e-320 to 1e308, NaN, both infinities, both zeros, the subnormals' ends, the normals' ends,
ties such as 0.125 to 2 digits) every text equals Python's ``'%.{p}g' % x`` and ``repr(x)``
(the C library's correctly rounded formatting, ties to even). Run with ``LC_ALL=de_DE.UTF-8``
(a locale compiled here with localedef) the program's own ``printf("%g", 1.5)`` prints "1,5"
while every sr_text line is the same as in the "C" locale; built with mingw and run under Wine
(msvcrt prints infinity as "1.#INF") it prints the same text.
"""
from __future__ import annotations

import math
import random
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

import native_hosts as nh

SRC = Path(__file__).resolve().parents[1] / "native" / "src"
PROGRAM = r"""
#include <locale.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sr_text.h"

static char *text(char *buf, size_t n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sr_text_vformat(buf, n, fmt, ap);
    va_end(ap);
    return buf;
}

int main(void)
{
    char line[64], buf[256];
    setlocale(LC_ALL, "");                      /* the environment's locale, as a host may */
    printf("printf %g\n", 1.5);
    while (fgets(line, sizeof line, stdin)) {
        uint64_t b = strtoull(line, NULL, 16);
        double x;
        memcpy(&x, &b, sizeof x);
        for (int sig = 1; sig <= 17; ++sig) {
            buf[0] = '\0';
            sr_text_num(buf, sizeof buf, x, sig);
            printf("%s ", buf);
        }
        buf[0] = '\0';
        sr_text_repr(buf, sizeof buf, x);
        printf("%s|", buf);
        printf("%s\n", text(buf, sizeof buf, "%g %.3g %.17g %d %u %lld %s %%", x, x, x,
                            (int)(b >> 33) - (1 << 30), (unsigned)(b >> 32),
                            (long long)(b ^ 0x8000000000000000ull), "s"));
    }
    return 0;
}
"""


def _values() -> list:
    rng = random.Random(20261)
    special = [0.0, -0.0, math.nan, math.inf, -math.inf, 5e-324, -5e-324,
               2.225073858507201e-308, 2.2250738585072014e-308, 1.7976931348623157e308,
               -1.7976931348623157e308, 0.125, 0.5, 1.5, 2.5, 0.1, 1e-5, 1e-4, 123456.5, 1e15,
               1e16, 1e21, 9.999999999999999e22, 1.0, 2.0 ** -1022, 2.0 ** -1023, 1 / 3]
    powers = [10.0 ** k for k in range(-320, 309)]
    rand = [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0] for _ in range(10000)]
    spread = [rng.choice((-1, 1)) * 10 ** rng.uniform(-307, 308) for _ in range(9000)]
    return special + powers + rand + spread


def _bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def _expected(x: float) -> str:
    b = _bits(x)
    nums = " ".join("%.*g" % (sig, x) for sig in range(1, 18))
    i, u, ll = (b >> 33) - (1 << 30), b >> 32, (b ^ (1 << 63)) - (1 << 64 if b ^ (1 << 63)
                                                                   >= 1 << 63 else 0)
    return f"{nums} {repr(x)}|{'%g %.3g %.17g' % (x, x, x)} {i} {u} {ll} s %"


def _compile(cc, tmp: Path, name: str, extra=()) -> Path:
    src = tmp / "prog.c"
    src.write_text(PROGRAM)
    exe = tmp / name
    cmd = [cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off",
           f"-I{SRC}", str(src), str(SRC / "sr_text.c"), "-o", str(exe), *extra]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    return exe


@pytest.fixture(scope="module")
def run_c(tmp_path_factory):
    cc = nh.c_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    tmp = tmp_path_factory.mktemp("sr_text")
    exe = _compile(cc, tmp, "prog", ["-lm"])
    values = _values()
    stdin = "".join(f"{_bits(x):016x}\n" for x in values)

    def run(env=None):
        r = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True,
                           env=env or nh.empty_env(), timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        return r.stdout.replace("\r\n", "\n").splitlines()
    return tmp, values, stdin, run


@pytest.mark.slow
def test_every_number_is_printed_as_python_prints_it(run_c):
    _, values, _, run = run_c
    lines = run()
    assert lines[0] == "printf 1.5"
    wrong = [(x, got, _expected(x)) for x, got in zip(values, lines[1:]) if got != _expected(x)]
    assert len(lines) == len(values) + 1 and not wrong, wrong[:5]


def _german(tmp: Path):
    """(LOCPATH, locale name) of a de_DE.UTF-8 compiled here, or None."""
    if shutil.which("localedef") is None:
        return None
    d = tmp / "locales"
    d.mkdir(exist_ok=True)
    subprocess.run(["localedef", "-i", "de_DE", "-f", "UTF-8", str(d / "de_DE.UTF-8")],
                   capture_output=True, text=True)
    return (str(d), "de_DE.UTF-8") if (d / "de_DE.UTF-8").is_dir() else None


@pytest.mark.slow
def test_a_german_locale_changes_printf_but_not_the_messages(run_c):
    tmp, values, _, run = run_c
    german = _german(tmp)
    if german is None:
        pytest.skip("localedef or the de_DE locale sources are missing")
    locpath, name = german
    lines = run(nh.empty_env({"LOCPATH": locpath, "LC_ALL": name}))
    assert lines[0] == "printf 1,5"                 # the host's locale is in effect
    assert lines[1:] == run()[1:]


@pytest.mark.slow
def test_windows_build_prints_the_same(run_c, tmp_path_factory):
    tmp, values, stdin, run = run_c
    mingw = nh.mingw()
    if not (mingw and nh.wine()):
        pytest.skip("needs x86_64-w64-mingw32-gcc and wine")
    exe = _compile(mingw, tmp, "prog.exe", ["-static-libgcc"])
    r = nh.wine_prefix(nh.work_dir(tmp_path_factory)).run([exe], input=stdin.encode())
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.decode().replace("\r\n", "\n").splitlines()
    assert lines[1:] == run()[1:]
