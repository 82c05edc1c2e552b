"""tests/wine.py's run: a Windows program that exits with 1 and prints nothing is run again
(twice, with a warning each time); one that prints, succeeds, or aborts (exit code 3, nothing
printed: a crash, not a launch failure) is run once."""
from __future__ import annotations

import subprocess
import warnings

import pytest

import native_hosts as nh

PROGRAM = r"""
#include <stdio.h>
#include <stdlib.h>
int main(int argc, char **argv)
{
    FILE *f = fopen(argv[1], "a");           /* one line per run: the runs are counted */
    fputs("run\n", f);
    fclose(f);
    if (argv[2][0] == 'p') printf("a line\n");
    if (argv[2][0] == 'a') abort();
    return atoi(argv[3]);
}
"""


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    nh.require(nh.wine(), "Wine")
    d = tmp_path_factory.mktemp("wine_run")
    (d / "p.c").write_text(PROGRAM)
    subprocess.run([nh.mingw(), "-o", str(d / "p.exe"), str(d / "p.c"), "-static-libgcc"],
                   check=True)
    return d, nh.wine_prefix(nh.work_dir(tmp_path_factory))


@pytest.mark.slow
@pytest.mark.parametrize("prints, code, runs", [("silent", 1, 3), ("prints", 1, 1),
                                                ("silent", 0, 1), ("abort", 3, 1)])
def test_a_silent_failure_is_run_again(program, prints, code, runs):
    d, prefix = program
    log = d / f"{prints}{code}.log"
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        r = prefix.run([d / "p.exe", nh.wine_path(log), prints, 0 if prints == "abort" else code])
    assert r.returncode == code
    assert log.read_text().count("run") == runs
    assert sum("did not start" in str(x.message) for x in w) == runs - 1
