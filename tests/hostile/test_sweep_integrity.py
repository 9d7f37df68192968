"""Hostile sweeps: a sweep file naming a scheduler, hostile sweep-file values, the local cluster's
sockets, two sweeps into one folder at once, and folders whose side files, table or journal were
deleted, corrupted or belong to something else. Each is refused in one paragraph before anything
runs, or runs without losing or mixing a row; nothing listens beyond 127.0.0.1."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

from tests.helpers import process_group_left
from tests.hostile.runner import (
    GOOD_TEXT,
    Outcome,
    assert_clean_error,
    assert_ok,
    run_cli,
    write,
)

GOOD = "loop.yaml"
VARY = ["--vary", "ctrl.k=values:1,2", "--method", "grid", "--workers", "1"]


def sweep_cli(cwd: Path, *args: str, timeout: float = 180) -> Outcome:
    return run_cli(["sweep", *args, "-q"], cwd, timeout=timeout)


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    write(tmp_path, GOOD, GOOD_TEXT)
    return tmp_path


def sweep_file(cwd: Path, extra: str, vary: str = "{ctrl.k: 'uniform:1:2'}") -> Path:
    return write(cwd, "mc.yaml", f"scenario: {GOOD}\nvary: {vary}\n"
                                 f"set: [experiment.stop=0.2]\n{extra}")


# -- the scheduler comes from the command line only --------------------------------------------
def test_a_sweep_file_naming_a_scheduler_is_refused_without_connecting(cwd: Path) -> None:
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    port = listener.getsockname()[1]
    connected: list[object] = []
    stop = threading.Event()

    def accept() -> None:
        while not stop.is_set():
            try:
                conn, peer = listener.accept()
            except TimeoutError:
                continue
            connected.append(peer)
            conn.close()

    watcher = threading.Thread(target=accept, daemon=True)
    watcher.start()
    try:
        sweep_file(cwd, f"scheduler: tcp://127.0.0.1:{port}\n")
        o = sweep_cli(cwd, "mc.yaml", "--out", "s")
    finally:
        stop.set()
        watcher.join()
        listener.close()
    assert_clean_error(o, mentions=["mc.yaml:4", "scheduler", "--scheduler"])
    assert connected == [], f"twmr sweep connected to the scheduler of a sweep file: {connected}"
    assert not (cwd / "s").exists()


# -- sweep-file values -------------------------------------------------------------------------
#: 405 bytes under metrics: that expand to 10**9 names
BOMB = "metrics: [&a [" + ", ".join("x" * 10) + "], " + ", ".join(
    f"&{k} [" + ", ".join([f"*{p}"] * 10) + "]" for p, k in zip("abcdefgh", "bcdefghi",
                                                                 strict=True)) + "]\n"


@pytest.mark.parametrize("extra, mentions", [
    ("workers: abc\n", ["mc.yaml:4", "workers", "'abc'"]),
    ("samples: true\n", ["samples", "True"]),
    ("seed: 1.5\n", ["mc.yaml:4", "seed", "1.5"]),
    ("metrics: tracking\n", ["metrics", "a list"]),
    ("keep_signals: 'false'\n", ["keep_signals", "true or false"]),
    ("samples: 1e9\n", ["samples"]),
    ("samples: 1000000000\n", ["1,000,000,000 runs"]),
    ("method: grid\n", ["1000000000"]),
    (BOMB, ["1,000,000 values"]),
], ids=["workers-abc", "samples-true", "seed-1.5", "metrics-string", "keep_signals-text",
        "samples-1e9-text", "samples-1e9", "grid-1e9", "alias-bomb"])
def test_hostile_sweep_file_values_are_refused_before_allocating(cwd: Path, extra: str,
                                                                 mentions: list[str]) -> None:
    grid = "{ctrl.k: 'grid:0:1:1000000000'}"
    sweep_file(cwd, extra, *([grid] if extra.startswith("method: grid") else []))
    o = sweep_cli(cwd, "mc.yaml", "--out", "s", timeout=60)
    assert_clean_error(o, mentions=mentions, rss_limit=400 * 2**20)
    assert not (cwd / "s").exists()


# -- the local cluster listens on 127.0.0.1 only ------------------------------------------------
def test_the_local_cluster_and_its_dashboard_listen_on_loopback_only(cwd: Path,
                                                                     caplog) -> None:
    psutil = pytest.importorskip("psutil")  # a dependency of distributed

    seen: list[tuple[str, int, str]] = []

    def listening(row: dict) -> None:
        me = psutil.Process()
        for proc in [me, *me.children(recursive=True)]:
            for conn in proc.net_connections(kind="inet"):
                if conn.status == psutil.CONN_LISTEN:
                    seen.append((conn.laddr.ip, conn.laddr.port, proc.name()))

    caplog.set_level("INFO", logger="twmr.sweep")
    from twmr.sweeps import spec_from, sweep

    spec = spec_from(str(cwd / GOOD), ["ctrl.k=values:1"], method="grid",
                     fixed=["experiment.stop=0.2"])
    outcome = sweep(spec, cwd / "s", workers=1, dashboard=True, on_row=listening)
    assert outcome.ran == 1
    assert len(seen) >= 3, seen  # the scheduler, its dashboard, the worker (and its nanny)
    exposed = [s for s in seen if s[0] not in ("127.0.0.1", "::1")]
    assert exposed == [], f"listening beyond the loopback interface: {exposed}"
    link = [r.getMessage() for r in caplog.records if "dashboard" in r.getMessage()]
    assert link and "http://127.0.0.1:" in link[0], link


# -- one writer per folder ---------------------------------------------------------------------
def test_a_second_concurrent_sweep_into_one_folder_is_refused_naming_the_holder(
        cwd: Path) -> None:
    args = [sys.executable, "-m", "twmr.cli", "sweep", GOOD, "--vary", "ctrl.k=uniform:1:3",
            "--samples", "12", "--workers", "1", "--set", "experiment.stop=5", "--out", "s",
            "-q"]
    first = subprocess.Popen([*args, "--seed", "1"], cwd=cwd, stderr=subprocess.PIPE,
                             text=True)
    lock = cwd / "s" / ".lock"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (lock.exists() and lock.read_text().strip()):
        time.sleep(0.05)
    holder = json.loads(lock.read_text())
    second = sweep_cli(cwd, GOOD, "--vary", "ctrl.k=uniform:1:3", "--samples", "12",
                       "--workers", "1", "--set", "experiment.stop=5", "--out", "s",
                       "--seed", "2")
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    assert holder["pid"] == first.pid
    assert_clean_error(second, mentions=["in use by another sweep", f"pid {first.pid}",
                                         socket.gethostname(), holder["started"]])
    table = pd.read_parquet(cwd / "s" / "runs.parquet")
    assert len(table) == 12 and table["run_id"].is_unique


def test_the_lock_of_a_dead_sweep_is_taken_over_with_a_message(cwd: Path) -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    folder = cwd / "s"
    folder.mkdir()
    write(folder, ".lock", json.dumps({"pid": dead.pid, "host": socket.gethostname(),
                                       "started": "2026-01-01T00:00:00+00:00"}) + "\n")
    o = sweep_cli(cwd, GOOD, *VARY, "--set", "experiment.stop=0.2", "--out", "s")
    assert_ok(o)
    assert f"taking over the lock of {folder}" in o.stderr and f"pid {dead.pid}" in o.stderr
    assert len(pd.read_parquet(folder / "runs.parquet")) == 2
    assert (folder / ".lock").read_text() == ""  # released at the end


# -- a folder is identified by its rows --------------------------------------------------------
@pytest.fixture(scope="module")
def done(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished sweep of 2 runs at experiment.stop=0.2 in <tmp>/s."""
    base = tmp_path_factory.mktemp("sweep")
    write(base, GOOD, GOOD_TEXT)
    o = sweep_cli(base, GOOD, *VARY, "--set", "experiment.stop=0.2", "--out", "s")
    assert_ok(o)
    assert len(pd.read_parquet(base / "s" / "runs.parquet")) == 2
    return base


def copy_of(done: Path, cwd: Path) -> Path:
    import shutil

    shutil.copytree(done / "s", cwd / "s")
    return cwd / "s"


def tamper_description(folder: Path, how: str) -> None:
    if how == "deleted":
        (folder / "sweep.json").unlink()
    else:
        (folder / "sweep.json").write_text("{ not json")


@pytest.mark.parametrize("how", ["deleted", "corrupted"])
def test_without_a_trustworthy_sweep_json_other_set_overrides_are_still_refused(
        done: Path, cwd: Path, how: str) -> None:
    folder = copy_of(done, cwd)
    tamper_description(folder, how)
    before = (folder / "runs.parquet").read_bytes()
    o = sweep_cli(cwd, GOOD, *VARY, "--set", "experiment.stop=0.1", "--out", "s")
    assert_clean_error(o, mentions=["holds runs of another sweep", "--out"])
    assert (folder / "runs.parquet").read_bytes() == before


@pytest.mark.parametrize("what, content, mentions", [
    ("runs.parquet", b"PAR1 this is no parquet table", ["runs.parquet cannot be read"]),
    ("runs.parquet", None, ["not a row written by `twmr sweep`"]),
    ("runs.jsonl", b'[1, 2]\n{"run_id": "x", "status": "ok"}\n', ["runs.jsonl:1"]),
    ("runs.jsonl", b'{"run_id": "abc", "status": "ok", "sweep_id": "0123"}\n',
     ["holds runs of another sweep", "'0123'"]),
], ids=["table-garbage", "table-foreign", "journal-not-a-row", "journal-foreign-row"])
def test_a_tampered_or_foreign_table_or_journal_is_refused(done: Path, cwd: Path, what: str,
                                                           content: bytes | None,
                                                           mentions: list[str]) -> None:
    folder = copy_of(done, cwd)
    if content is None:  # a parquet table of something else
        pd.DataFrame({"x": [1.0, 2.0]}).to_parquet(folder / what)
    else:
        (folder / what).write_bytes(content)
    o = sweep_cli(cwd, GOOD, *VARY, "--set", "experiment.stop=0.2", "--out", "s")
    assert_clean_error(o, mentions=mentions)


def test_out_pointing_at_a_foreign_folder_leaves_it_as_it_was(cwd: Path) -> None:
    foreign = cwd / "theirs"
    write(foreign, "sweep.json", '{"owner": "another tool"}\n')
    write(foreign, "notes.txt", "precious\n")
    sweep_file(cwd, "out: theirs\n")
    o = sweep_cli(cwd, "mc.yaml")
    assert_clean_error(o, mentions=["theirs", "notes.txt", "not a sweep's"])
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt", "sweep.json"]
    assert (foreign / "sweep.json").read_text() == '{"owner": "another tool"}\n'
    alone = cwd / "alone"
    write(alone, "sweep.json", '{"owner": "another tool"}\n')
    o = sweep_cli(cwd, "mc.yaml", "--out", "alone")
    assert_clean_error(o, mentions=["sweep.json is not a description written by `twmr sweep`"])
    assert (alone / "sweep.json").read_text() == '{"owner": "another tool"}\n'


# -- Ctrl-C ------------------------------------------------------------------------------------
def _a_worker_process_started(pgid: int) -> bool:
    """A Dask nanny or worker (a multiprocessing child) is running in process group `pgid`."""
    found = subprocess.run(["pgrep", "-g", str(pgid), "-f", "spawn_main"], capture_output=True,
                           text=True)
    return bool(found.stdout.strip())


@pytest.mark.parametrize("when", ["cluster-starting", "workers-starting", "runs-under-way"])
def test_ctrl_c_of_a_sweep_is_one_line_and_keeps_every_finished_row(cwd: Path,
                                                                    when: str) -> None:
    """Ctrl-C as a terminal sends it: to the whole process group, Dask workers included."""
    import signal

    proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", "sweep", GOOD, "--vary",
                             "ctrl.k=uniform:1:3", "--samples", "400", "--workers", "2",
                             "--set", "experiment.stop=2", "--out", "s", "-q"], cwd=cwd,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    folder = cwd / "s"
    ready = (folder / ".lock") if when == "cluster-starting" else (folder / "runs.jsonl")
    deadline = time.monotonic() + 120
    if when == "workers-starting":  # the cluster is being built: Ctrl-C is held, not lost
        while time.monotonic() < deadline and not _a_worker_process_started(proc.pid):
            time.sleep(0.005)
    else:
        while time.monotonic() < deadline and not (ready.exists() and ready.read_text().strip()):
            time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=90)
    o = Outcome(["sweep", "..."], cwd, proc.returncode, "", err, 0.0, proc.pid, 0)
    para = assert_clean_error(o, fix=False, mentions=["interrupted (Ctrl-C)"])
    assert proc.returncode == 130 and len(para) == 1, o.describe()
    assert (folder / ".lock").read_text() == ""
    table = pd.read_parquet(folder / "runs.parquet") if (folder / "runs.parquet").exists() \
        else pd.DataFrame()  # stopped before any run was handed out
    assert len(table) < 400
    if when == "runs-under-way":
        assert len(table) >= 1 and (table["status"] == "ok").all()
    assert process_group_left(proc.pid) == ""  # no worker left behind
