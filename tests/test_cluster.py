"""Monte Carlo and sweep on a real Dask cluster whose workers cannot see the client's files.

A ``dask scheduler`` (on a port the system picks) and two ``dask worker`` processes on loopback,
each worker in its own mount namespace (``unshare --mount``) where a tmpfs hides this test
process's pytest temporary folder (the client's only): the client's build folders, tables and .ssp files do not exist for the workers, as on
machines that share no file system with the client and have only the package installed. The
Monte Carlo and the sweep run through the CLI against ``--scheduler``; their rows must equal,
cell for cell, those of the same commands on a local cluster (the same library on the same
machine computes both, so the numbers are the same bits), with no failed row; the excitation
design's scores on the cluster equal those computed in this process.

Needs Linux and the right to create a mount namespace (root, as in CI); skipped otherwise.
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from spacerobot.system import cli  # noqa: E402
from spacerobot.system.montecarlo import read_results  # noqa: E402
from spacerobot.system.sweep import read_table  # noqa: E402

pytestmark = pytest.mark.slow

#: columns that name where and how long a row ran, not what it computed
PLACE = ("wall_time", "worker")


def _unshare_reason() -> str:
    """Why the workers cannot be given a private mount namespace here ("" if they can)."""
    if not sys.platform.startswith("linux"):
        return "needs Linux mount namespaces"
    if shutil.which("unshare") is None or shutil.which("mount") is None:
        return "needs unshare and mount (util-linux)"
    probe = subprocess.run(["unshare", "--mount", "--propagation", "private", "true"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        return ("creating a mount namespace is not permitted here (needs root, as in CI): "
                + probe.stderr.strip())
    return ""


def _address_of(scheduler_file: Path, proc: subprocess.Popen, timeout: float = 60) -> str:
    """The address the scheduler bound (``--port 0``: the system's free port, no race with
    another process), from the file it writes once it listens."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None:
        with contextlib.suppress(FileNotFoundError, json.JSONDecodeError, KeyError):
            return json.loads(scheduler_file.read_text())["address"]
        time.sleep(0.2)
    raise RuntimeError(f"the scheduler wrote no address to {scheduler_file}")


def _stop(proc: subprocess.Popen) -> None:
    """End the process group this test started for ``proc`` (SIGTERM, then SIGKILL)."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """``(tcp://127.0.0.1:PORT, worker pids)``: a scheduler with two one-thread workers that
    cannot see pytest's temporary folder; the processes end with the module."""
    reason = _unshare_reason()
    if reason:
        pytest.skip(reason)
    from distributed import Client

    hidden = tmp_path_factory.getbasetemp()
    scratch = Path(tempfile.mkdtemp(prefix="spacerobot-workers-"))   # not under `hidden`
    logs = scratch / "logs"
    logs.mkdir()
    procs = []

    def start(name, argv):
        log = open(logs / f"{name}.log", "w")
        procs.append(subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                      start_new_session=True, cwd=scratch))
        log.close()

    dask = [sys.executable, "-m", "dask"]
    try:
        start("scheduler", dask + ["scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--no-dashboard", "--scheduler-file",
                                   str(scratch / "scheduler.json")])
        address = _address_of(scratch / "scheduler.json", procs[0])
        for k in range(2):
            local = scratch / f"worker-{k}"
            local.mkdir()
            worker = dask + ["worker", address, "--nthreads", "1", "--no-nanny",
                             "--no-dashboard", "--name", f"hidden-{k}", "--local-directory",
                             str(local), "--death-timeout", "60"]
            # the worker's own view of the machine: pytest's temporary folder is an empty tmpfs
            script = (f"mount -t tmpfs tmpfs {_q(hidden)} && exec "
                      + " ".join(_q(a) for a in worker))
            start(f"worker-{k}", ["unshare", "--mount", "--propagation", "private",
                                  "sh", "-c", script])
        with Client(address, timeout=60) as c:
            c.wait_for_workers(2, timeout=60)
        yield address, {p.pid for p in procs[1:]}     # unshare and sh exec the worker
    except Exception:
        for p in procs:
            _stop(p)
        text = "\n".join(f"--- {f.name}\n{f.read_text()[-2000:]}" for f in logs.iterdir())
        raise RuntimeError(f"the local cluster did not start:\n{text}")
    finally:
        for p in reversed(procs):
            _stop(p)
        shutil.rmtree(scratch, ignore_errors=True)


def _q(x) -> str:
    import shlex
    return shlex.quote(str(x))


def test_workers_cannot_see_the_clients_folders(scheduler, tmp_path):
    """The set-up holds: a file the client sees is not there for the workers."""
    from distributed import Client

    address, pids = scheduler
    marker = tmp_path / "marker"
    marker.write_text("the client's")
    with Client(address) as c:
        seen = c.run(os.path.exists, str(marker))
        where = set(c.run(os.getpid).values())
    assert marker.exists() and len(seen) == 2 and not any(seen.values()), seen
    assert where == pids


def _same_rows(remote, local, key, pids):
    """Every row of ``remote`` ok, run by one of the workers ``pids`` and equal to ``local``'s
    row of the same id, cell for cell (numbers as numbers, NaN equal to NaN), but for where and
    how long it ran."""
    assert len(remote) == len(local) > 0
    local = {r[key]: r for r in local}
    for r in remote:
        assert r["status"] == "ok", r["error"]
        ref = local[r[key]]
        for col, v in r.items():
            if col in PLACE:
                continue
            try:
                a, b = float(v), float(ref[col])
            except ValueError:
                assert v == ref[col], (r[key], col, v, ref[col])
                continue
            assert a == b or (math.isnan(a) and math.isnan(b)), (r[key], col, v, ref[col])
    assert {int(r["worker"].rsplit(":", 1)[1]) for r in remote} <= pids


def test_montecarlo_through_the_sensors_on_hidden_workers(scheduler, tmp_path):
    address, pids = scheduler
    common = ["montecarlo", "--robot", "spatial", "--sensors", "--cases", "3", "--stop-time",
              "4", "--no-progress"]
    assert cli.main(common + ["--scheduler", address, "--out", str(tmp_path / "c.csv")]) == 0
    assert cli.main(common + ["--workers", "2", "--out", str(tmp_path / "l.csv")]) == 0
    remote, local = read_results(tmp_path / "c.csv"), read_results(tmp_path / "l.csv")
    assert len(remote) == 3
    _same_rows(remote, local, "case_id", pids)


def test_sweep_on_hidden_workers(scheduler, tmp_path):
    address, pids = scheduler
    common = ["sweep", "--robot", "planar", "--method", "momentum,force", "--v0", "0,10;50,50",
              "--F-max", "0.1", "--stop-time", "1.5", "--no-progress"]
    assert cli.main(common + ["--scheduler", address, "--out", str(tmp_path / "c.csv")]) == 0
    assert cli.main(common + ["--workers", "2", "--out", str(tmp_path / "l.csv")]) == 0
    remote, local = read_table(tmp_path / "c.csv"), read_table(tmp_path / "l.csv")
    assert len(remote) == 4
    _same_rows(remote, local, "sweep_id", pids)


def test_design_excitation_on_hidden_workers(scheduler):
    """The same candidates' scores on the cluster as in this process, to the bit."""
    from spacerobot.system.design import Candidate, design

    address, _ = scheduler
    cands = [Candidate(30.0), Candidate(7.5)]
    remote = design("spatial", cands, cases=1, stop_time=20.0, scheduler=address)
    local = design("spatial", cands, cases=1, stop_time=20.0, workers=1)
    for ci in range(len(cands)):
        assert remote.scores(ci).tolist() == local.scores(ci).tolist()
    assert remote.table() == local.table()
