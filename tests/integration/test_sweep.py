"""Sweeps on a real Dask cluster (`LocalCluster` of 2 worker processes): the same figures as the
runs done one by one, failures recorded with their errors while the others finish, a second
invocation that runs nothing new, reproducible samples, the CLI and the sweep file."""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import twmr
from tests.helpers import process_group_left
from twmr.sweeps import SweepError, SweepSpec, parse_vary, run_id
from twmr.sweeps.folder import identity

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
SHORT = ["experiment.stop=1.0"]


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as c:
        yield c.scheduler_address


def test_twenty_runs_give_the_figures_of_the_same_runs_one_by_one(cluster, tmp_path) -> None:
    outcome = twmr.sweep(PAPER, {"plant.scale": "uniform:0.9:1.2",
                                 "plant.pose[2]": "normal:0:0.001"},
                         samples=20, method="lhs", seed=7, out=tmp_path / "s",
                         scheduler=cluster, metrics=["tracking"], overrides=SHORT)
    assert (outcome.ran, outcome.failed) == (20, 0)
    table = pd.read_parquet(tmp_path / "s" / "runs.parquet")
    assert len(table) == 20 and list(table["sample"]) == list(range(20))
    assert len(set(table["worker"])) == 2  # both worker processes ran some
    for _, row in table.iloc[::4].iterrows():  # five of them again, here, one by one
        pose = list(twmr.load(PAPER).system.components["plant"].get("pose"))
        pose[1] = row["plant.pose[2]"]
        alone = twmr.simulate(twmr.load(PAPER, [*SHORT, f"plant.scale={row['plant.scale']!r}",
                                                f"plant.pose={pose!r}"]),
                              metrics=["tracking"])
        for key, value in alone.summary["metrics"].items():
            assert row[key] == value, key


def test_a_failing_run_is_a_row_with_its_error_and_the_others_finish(cluster, tmp_path) -> None:
    scenario = tmp_path / "blowup.yaml"
    scenario.write_text("""
components:
  src: {kind: sine, parameters: {amplitude: 10.0, frequency: 1.0}}
  g: {kind: gain, parameters: {k: 1.0}}
connections: [src.y -> g.u]
experiment: {start: 0.0, stop: 0.5, step: 0.01}
""")
    outcome = twmr.sweep(scenario, ["g.k=values:1,2,1e308,3", "src.frequency=values:-1,1"],
                         method="grid", out=tmp_path / "b", scheduler=cluster)
    table = outcome.frame()
    assert len(table) == 8 and outcome.failed == 5
    ok = table[table["status"] == "ok"]
    assert sorted(ok["g.k"]) == [1.0, 2.0, 3.0] and (ok["error"] == "").all()
    out_of_range = table[table["src.frequency"] == -1]
    assert (out_of_range["status"] == "failed").all()
    assert out_of_range["error"].str.contains("below the minimum 0.0").all()
    blown = table[(table["g.k"] == 1e308) & (table["src.frequency"] == 1)].iloc[0]
    assert blown["status"] == "failed" and "is inf (not finite)" in blown["error"]


def test_a_second_invocation_runs_nothing_new_and_a_larger_one_only_the_new(cluster,
                                                                              tmp_path) -> None:
    args = dict(out=tmp_path / "r", scheduler=cluster, overrides=SHORT)
    first = twmr.sweep(PAPER, ["plant.scale=grid:0.9:1.1:3"], method="grid", **args)
    assert first.ran == 3
    again = twmr.sweep(PAPER, ["plant.scale=grid:0.9:1.1:3"], method="grid", **args)
    assert (again.ran, again.skipped) == (0, 3)
    more = twmr.sweep(PAPER, ["plant.scale=grid:0.9:1.1:5"], method="grid", **args)
    assert (more.ran, more.skipped) == (2, 3)  # 0.95 and 1.05 are new
    assert len(pd.read_parquet(tmp_path / "r" / "runs.parquet")) == 5


def test_a_journal_left_by_a_killed_sweep_counts_as_done(cluster, tmp_path) -> None:
    folder = tmp_path / "k"
    folder.mkdir()
    spec_values = {"plant.scale": 1.0}
    sweep_id = identity(SweepSpec(str(PAPER), [], fixed=SHORT), PAPER.read_text())["sweep_id"]
    row = {"run_id": run_id(spec_values, SHORT), "sweep_id": sweep_id, "sample": 0,
           **spec_values, "status": "ok",
           "error": "", "wall_time_s": 1.0, "step_time_s": 1.0, "worker": "w"}
    (folder / "runs.jsonl").write_text(json.dumps(row) + "\n{\"run_id\": \"cut sho")
    outcome = twmr.sweep(PAPER, ["plant.scale=values:1.0,1.1"], method="grid", out=folder,
                         scheduler=cluster, overrides=SHORT)
    assert (outcome.ran, outcome.skipped) == (1, 1)
    assert not (folder / "runs.jsonl").exists() and len(outcome.rows) == 2


@pytest.mark.parametrize("method", ["random", "lhs"])
def test_samples_are_reproducible_from_the_seed(method) -> None:
    def table(seed: int) -> list[dict]:
        return SweepSpec("x.yaml", [parse_vary("a.b=uniform:0:1"),
                                    parse_vary("c.d=normal:5:2"),
                                    parse_vary("e.f=values:1,2,3")], samples=50,
                         method=method, seed=seed).samples_table()

    assert table(3) == table(3) and table(3) != table(4)
    if method == "lhs":  # one sample in each of the 50 strata of every uniform variable
        u = np.array([r["a.b"] for r in table(3)])
        assert sorted(np.floor(u * 50).astype(int)) == list(range(50))


@pytest.mark.parametrize("text, message", [
    ("plant.scale", "cannot read it"),
    ("plant.scale=uniform:2:1", "LO 2 is above HI 1"),
    ("plant.scale=gauss:1:2", "not a distribution"),
    ("plant.scale=grid:0:1:2.5", "not a positive whole number"),
    ("plant.scale=normal:1:-1", "SIGMA -1 is negative"),
])
def test_bad_vary_is_explained(text, message) -> None:
    with pytest.raises(SweepError, match=message):
        parse_vary(text)


def test_cli_sweep_file_progress_and_errors(tmp_path) -> None:
    sweep_file = tmp_path / "mc.yaml"
    sweep_file.write_text(f"""
scenario: {PAPER}
vary: {{plant.scale: "uniform:0.95:1.05"}}
samples: 4
seed: 1
metrics: [tracking]
set: [experiment.stop=0.5]
""")
    out = tmp_path / "cli"
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "sweep", str(sweep_file),
                           "--workers", "2", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "4 run(s) done now (0 failed)" in done.stderr
    table = pd.read_parquet(out / "runs.parquet")
    assert len(table) == 4 and "mse_x" in table and (table["status"] == "ok").all()
    bad = subprocess.run([sys.executable, "-m", "twmr.cli", "sweep", str(PAPER), "--vary",
                          "plant.nosuch=uniform:0:1", "--workers", "1", "--out",
                          str(tmp_path / "bad")], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 1 and "Traceback" not in bad.stderr
    assert "plant" in bad.stderr and "nosuch" in bad.stderr


def test_ctrl_c_stops_the_sweep_cleanly_and_keeps_the_finished_runs(tmp_path) -> None:
    """Ctrl-C in a terminal reaches the whole process group, Dask workers included."""
    import os
    import signal
    import time

    out = tmp_path / "stop"
    proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", "sweep", str(PAPER), "--vary",
                             "plant.scale=uniform:0.9:1.1", "--samples", "400", "--workers", "2",
                             "--out", str(out)], stderr=subprocess.PIPE, text=True,
                            start_new_session=True,  # as from a terminal, even if this test
                            # runs in the background, where Ctrl-C is ignored and inherited so
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    journal = out / "runs.jsonl"
    while time.monotonic() < deadline and not (journal.exists() and journal.read_text()):
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted (Ctrl-C)" in err
    table = pd.read_parquet(out / "runs.parquet")
    assert 1 <= len(table) < 400 and (table["status"] == "ok").all()
    assert process_group_left(proc.pid) == ""  # no worker left behind


def test_a_run_that_crashes_its_worker_is_a_row_and_the_others_finish(tmp_path) -> None:
    from tests.fmu_build import build_c_fmu

    faulty = build_c_fmu("faulty", tmp_path)
    scenario = tmp_path / "faulty.yaml"
    scenario.write_text(f"""
components:
  f: {{kind: fmu, parameters: {{path: {faulty}, fail_after: 5}}}}
open: [f.u]
experiment: {{start: 0.0, stop: 0.2, step: 0.01}}
""")
    outcome = twmr.sweep(scenario, ["f.mode=values:0,1"], method="grid", workers=2,
                         out=tmp_path / "crash")  # mode 1: a segmentation fault in doStep
    table = outcome.frame().set_index("f.mode")
    assert table.loc[0, "status"] == "ok", table.loc[0, "error"]
    assert table.loc[1, "status"] == "failed"
    assert "worker process running it died" in table.loc[1, "error"]


def test_a_folder_of_another_scenario_or_metrics_is_refused(cluster, tmp_path) -> None:
    args = dict(out=tmp_path / "one", scheduler=cluster, overrides=SHORT, method="grid")
    twmr.sweep(PAPER, ["plant.scale=values:1.0"], **args)
    smc = ROOT / "scenarios" / "paper_trajectory1_smc.yaml"
    with pytest.raises(SweepError, match="another scenario"):
        twmr.sweep(smc, ["plant.scale=values:1.0"], **args)
    with pytest.raises(SweepError, match="other --metrics"):
        twmr.sweep(PAPER, ["plant.scale=values:1.0"], metrics=["tracking"], **args)


def test_a_run_that_kills_its_worker_fails_alone_not_its_batch(tmp_path) -> None:
    """Eight runs on one worker go in batches of two; the run that kills its worker process
    (SIGKILL in do_step) takes its batch down, the batch's runs are tried again one by one, and
    only that run is recorded as failed."""
    (tmp_path / "killer.py").write_text(
        "import os, signal\n"
        "from twmr.core import Component, Input, Output, Parameter\n\n\n"
        "class Killer(Component):\n"
        "    u = Input(start=0.0)\n"
        "    y = Output(start=0.0)\n"
        "    which = Parameter(0.0)\n\n"
        "    def do_step(self, t: float, h: float) -> None:\n"
        "        if self.which == 3.0:\n"
        "            os.kill(os.getpid(), signal.SIGKILL)\n"
        "        self.y = self.which\n")
    scenario = tmp_path / "killer.yaml"
    scenario.write_text("components:\n  k: {kind: 'killer.py:Killer'}\nopen: [k.u]\n"
                        "experiment: {start: 0.0, stop: 0.05, step: 0.01}\n")
    outcome = twmr.sweep(scenario, ["k.which=values:1,2,3,4,5,6,7,8"], method="grid",
                         workers=1, out=tmp_path / "kill")
    table = outcome.frame().set_index("k.which")
    assert len(table) == 8
    assert table.loc[3.0, "status"] == "failed"
    assert "worker process running it died" in table.loc[3.0, "error"]
    assert (table.drop(index=3.0)["status"] == "ok").all(), table[["status", "error"]]


@pytest.mark.parametrize("configured", [None, "131072"])
def test_a_sweeps_workers_start_without_dasks_malloc_trim_default(monkeypatch, configured) -> None:
    """Dask's default MALLOC_TRIM_THRESHOLD_ is left out of a sweep's worker processes (it
    makes glibc map every run's row buffers afresh); a value the user configured is kept."""
    import os

    import dask
    import dask.distributed  # (its configuration is loaded with it)

    from twmr.sweeps.engine import SPAWN_ENVIRON, dask_client

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    environ = dict(dask.config.get(SPAWN_ENVIRON))
    assert environ.get("MALLOC_TRIM_THRESHOLD_") == 65536  # Dask's default, as the code knows it
    if configured is not None:
        environ["MALLOC_TRIM_THRESHOLD_"] = configured
    with dask.config.set({SPAWN_ENVIRON: environ}):
        client, cluster = dask_client(1, None)
    try:
        seen = client.run(lambda: os.environ.get("MALLOC_TRIM_THRESHOLD_"))
    finally:
        client.close()
        cluster.close()
    assert list(seen.values()) == [configured]


@pytest.mark.timeout(300)
def test_a_sweep_whose_workers_are_gone_for_good_fails_the_runs_left(tmp_path, monkeypatch
                                                                     ) -> None:
    """The cluster loses its only worker for good while runs wait (scaled to none, as when a
    nanny cannot start another): the sweep waits NO_WORKER_PATIENCE (2 s here), then fails the
    runs left, saying so, and ends with every row in its table."""
    import threading

    from twmr.sweeps import engine

    monkeypatch.setattr(engine, "NO_WORKER_PATIENCE", 2.0)
    made = engine.dask_client

    def one_worker_then_none(workers, scheduler, dashboard=False):
        client, cluster = made(1, scheduler, dashboard)

        def scale_down() -> None:
            journal = tmp_path / "gone" / "runs.jsonl"
            while not (journal.exists() and journal.read_text().strip()):
                time.sleep(0.05)
            cluster.scale(0)

        threading.Thread(target=scale_down, daemon=True).start()
        return client, cluster

    monkeypatch.setattr(engine, "dask_client", one_worker_then_none)
    (tmp_path / "slow.py").write_text(
        "import time\n"
        "from twmr.core import Component, Input, Output, Parameter\n\n\n"
        "class Slow(Component):\n"
        "    u = Input(start=0.0)\n"
        "    y = Output(start=0.0)\n"
        "    which = Parameter(0.0)\n\n"
        "    def do_step(self, t: float, h: float) -> None:\n"
        "        time.sleep(0.2)\n"
        "        self.y = self.which\n")
    scenario = tmp_path / "slow.yaml"
    scenario.write_text("components:\n  k: {kind: 'slow.py:Slow'}\nopen: [k.u]\n"
                        "experiment: {start: 0.0, stop: 0.02, step: 0.01}\n")
    outcome = twmr.sweep(scenario, [f"k.which=values:{','.join(map(str, range(1, 9)))}"],
                         method="grid", workers=1, out=tmp_path / "gone")
    table = outcome.frame()
    assert len(table) == 8, table[["run_id", "k.which", "status", "error"]].to_string()
    failed = table[table["status"] == "failed"]
    assert len(failed) >= 1
    assert all("no Dask worker was left" in e for e in failed["error"]), failed["error"]
    assert len(pd.read_parquet(tmp_path / "gone" / "runs.parquet")) == 8
