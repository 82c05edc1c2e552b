"""A built system sent to the workers by value (spacerobot.system.sweep.ship): the archive
written once per machine under its content's hash, atomically, reused, replaced when damaged,
and safe when several tasks of one worker write it at once."""
import hashlib
import os
import pickle
import threading

import pytest

from spacerobot.system.sweep import ship
from spacerobot.system.sweep.ship import FOLDER, ShippedSystem, run_shipped


@pytest.fixture(autouse=True)
def fresh_memo():
    ship._LOCAL.clear()
    yield
    ship._LOCAL.clear()


def _archive(tmp_path, name="robot.ssp", data=b"PK\x03\x04 some zip bytes" * 1000):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def test_written_once_under_the_hash(tmp_path):
    src = _archive(tmp_path)
    s = ShippedSystem.read(src)
    assert s.digest == hashlib.sha256(src.read_bytes()).hexdigest()
    assert s.key == f"spacerobot-system-{s.digest}" and str(len(s.data)) in repr(s)
    root = tmp_path / "worker"
    path = s.local_path(root)
    assert path == root / FOLDER / s.digest / "robot.ssp"
    assert path.read_bytes() == src.read_bytes()
    stamp = path.stat().st_mtime_ns
    ship._LOCAL.clear()                               # another process: checks, reuses
    assert s.local_path(root) == path and path.stat().st_mtime_ns == stamp
    assert os.listdir(path.parent) == ["robot.ssp"]   # no temporary file left


def test_two_systems_never_share_a_file(tmp_path):
    a = ShippedSystem.read(_archive(tmp_path, "a.ssp", b"first"))
    b = ShippedSystem.read(_archive(tmp_path, "b.ssp", b"second"))
    (tmp_path / "other").mkdir()
    c = ShippedSystem.read(_archive(tmp_path / "other", "a.ssp", b"third, same name"))
    root = tmp_path / "worker"
    paths = {a.local_path(root), b.local_path(root), c.local_path(root)}
    assert len(paths) == 3
    assert {p.read_bytes() for p in paths} == {b"first", b"second", b"third, same name"}


def test_a_damaged_file_is_replaced(tmp_path):
    s = ShippedSystem.read(_archive(tmp_path))
    root = tmp_path / "worker"
    path = s.local_path(root)
    path.write_bytes(b"truncated")                    # e.g. a disk that filled up
    ship._LOCAL.clear()
    assert s.local_path(root).read_bytes() == s.data


def test_tasks_writing_at_once_never_read_a_partial_archive(tmp_path):
    """Sixteen threads (the tasks of one worker) ask for the archive at the same time: every
    one gets the complete bytes, and only the archive is left in its folder."""
    s = ShippedSystem.read(_archive(tmp_path, data=os.urandom(3_000_000)))
    root = tmp_path / "worker"
    seen, errors = [], []
    go = threading.Barrier(16)

    def task():
        try:
            go.wait()
            p = s.local_path(root)
            seen.append(p.read_bytes() == s.data)
        except Exception as e:  # noqa: BLE001
            errors.append(e)
    threads = [threading.Thread(target=task) for _ in range(16)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and seen == [True] * 16
    assert os.listdir(root / FOLDER / s.digest) == ["robot.ssp"]


def test_travels_by_value_and_runs_the_task_on_the_local_copy(tmp_path, monkeypatch):
    """Pickled (as Dask sends it) it carries the bytes; outside a Dask worker the copy goes to
    the temp directory; the task gets its path."""
    s = pickle.loads(pickle.dumps(ShippedSystem.read(_archive(tmp_path))))
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()

    def task(item, ssp_path, runner):
        return item, open(ssp_path, "rb").read() == s.data, ssp_path, runner
    item, same, where, runner = run_shipped(task, "item", s, "m:f")
    assert (item, same, runner) == ("item", True, "m:f")
    assert where.startswith(str(tmp_path / "tmp" / FOLDER))


def test_a_folder_or_missing_file_is_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match="a folder"):
        ShippedSystem.read(tmp_path)
    with pytest.raises(FileNotFoundError, match="not a .ssp file"):
        ShippedSystem.read(tmp_path / "nope.ssp")


def test_a_worker_with_another_version_refuses(tmp_path, monkeypatch):
    from spacerobot import __version__
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    s = ShippedSystem.read(_archive(tmp_path))
    with pytest.raises(RuntimeError, match=f"the client 0.0.0-other: install"):
        run_shipped(lambda *a: None, "item", s, "m:f", "0.0.0-other")
    assert run_shipped(lambda i, p, r: i, "item", s, "m:f", __version__) == "item"
