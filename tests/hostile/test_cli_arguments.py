"""Hostile command lines: unknown subcommands and options, bad values, missing or corrupt
files for every subcommand, closed output pipes, and the global options placed after the
subcommand. Each is refused with a clean error (argparse's own usage error for mistakes in the
command line itself) or works; never a traceback, never a hang."""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.hostile.runner import (
    BENCH,
    GOOD_TEXT,
    Outcome,
    assert_clean_error,
    assert_no_traceback,
    assert_ok,
    assert_writes_only_under,
    run_cli,
    run_shell,
    write,
)

GOOD = "loop.yaml"


@pytest.fixture(scope="module")
def odrive_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The frame log of a 0.05 s bench run (ODrive drives, emulated)."""
    cwd = tmp_path_factory.mktemp("bench")
    o = run_cli(["run", str(BENCH), "--set", "experiment.stop=0.05", "--out", "out", "-q"], cwd,
                timeout=60)
    assert_ok(o)
    log = cwd / "out" / "motor_frames.blf"
    assert log.is_file() and log.stat().st_size > 0, o.describe()
    return log


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    folder = tmp_path / "cwd"
    folder.mkdir()
    write(folder, GOOD, GOOD_TEXT)
    write(folder, "notes.txt", "just some text, not an FMU\n")
    write(folder, "empty.blf", b"")
    write(folder, "random.blf", os.urandom(8192))
    write(folder, "frames.blf", "time_s,direction,node,signal,value\n0.0,Rx,0,angle,0\n")
    write(folder, "random.asc", "this is not\tan ASC\nlog at all }}}\n" * 20)
    write(folder, "frames.txt", "0 1 2 3\n")
    return folder


@dataclass
class Case:
    args: list[str]
    expect: str = "error"               # "error" | "ok"
    mentions: tuple[str, ...] = ()
    usage: bool = False                 # argparse's usage error is an accepted answer
    fix: bool = True
    timeout: float = 30


CASES: dict[str, Case] = {
    "unknown-subcommand": Case(["frobnicate"], mentions=("frobnicate",), usage=True),
    "no-arguments": Case([], usage=True),
    "only-a-global-option": Case(["-q"], usage=True),
    "unknown-option": Case(["run", GOOD, "--fast-please"], mentions=("--fast-please",),
                           usage=True),
    "run-without-scenario": Case(["run"], usage=True),
    "run-extra-positional": Case(["check", GOOD, "extra.yaml"], mentions=("extra.yaml",),
                                 usage=True),
    "run-out-without-value": Case(["run", GOOD, "--out"], mentions=("--out",), usage=True),
    "run-set-without-value": Case(["run", GOOD, "--set"], mentions=("--set",), usage=True),
    "run-format-xyz": Case(["run", GOOD, "--format", "xyz", "--out", "out"],
                           mentions=("xyz",)),
    "run-format-mixed-good-and-bad": Case(["run", GOOD, "--format", "csv,xlsx", "--out", "out"],
                                          mentions=("xlsx",)),
    "run-metrics-nope": Case(["run", GOOD, "--metrics", "nope", "--out", "out"],
                             mentions=("nope",)),
    "run-metrics-tracking-without-a-robot": Case(["run", GOOD, "--metrics", "tracking",
                                                  "--out", "out"], mentions=("tracking",)),
    "run-set-without-equals": Case(["run", GOOD, "--set", "ctrlk", "--out", "out"],
                                   mentions=("ctrlk",)),
    "run-missing-scenario": Case(["run", "missing.yaml", "--out", "out"],
                                 mentions=("missing.yaml",)),
    "check-set-without-equals": Case(["check", GOOD, "--set", "ctrl.k"],
                                     mentions=("ctrl.k",)),
    "components-nokind": Case(["components", "nokind"], mentions=("nokind",)),
    "components-good-and-bad-kind": Case(["components", "gain", "nokind"],
                                         mentions=("nokind",)),
    "inspect-missing-fmu": Case(["inspect", "missing.fmu"], mentions=("missing.fmu",)),
    "inspect-text-file": Case(["inspect", "notes.txt"], mentions=("notes.txt",)),
    "inspect-a-directory": Case(["inspect", "."]),
    "export-nokind": Case(["export", "nokind", "--out", "x.fmu"], mentions=("nokind",)),
    "export-set-without-equals": Case(["export", "gain", "--set", "k", "--out", "x.fmu"],
                                      mentions=("k",)),
    "export-unknown-parameter": Case(["export", "gain", "--set", "kk=1", "--out", "x.fmu"],
                                     mentions=("kk",)),
    "export-out-under-a-file": Case(["export", "gain", "--out", "notes.txt/gain.fmu"],
                                    mentions=("notes.txt",)),
    "replay-missing-file": Case(["replay", "missing.blf"], mentions=("missing.blf",)),
    "replay-empty-file": Case(["replay", "empty.blf"], mentions=("empty.blf",)),
    "replay-random-bytes": Case(["replay", "random.blf"], mentions=("random.blf",)),
    "replay-csv-renamed-blf": Case(["replay", "frames.blf"], mentions=("frames.blf",)),
    "replay-garbage-asc": Case(["replay", "random.asc"], mentions=("random.asc",)),
    "replay-unknown-extension": Case(["replay", "frames.txt"], mentions=("frames.txt",)),
    "replay-a-directory": Case(["replay", "."]),
    "plot-without-argument": Case(["plot"], usage=True),
    "compare-missing-files": Case(["compare", "a.yaml", "b.yaml"], mentions=("a.yaml",)),
    "emulate-drive-eds-missing": Case(["emulate-drive", "--option", "eds=missing.eds"],
                                      mentions=("eds", "odrive"), timeout=5),
    "emulate-drive-cia402-eds-missing": Case(["emulate-drive", "--protocol", "cia402", "--option",
                                              "eds=missing.eds"], mentions=("missing.eds",),
                                             timeout=5),
    "emulate-drive-node-200": Case(["emulate-drive", "--node", "200"], mentions=("200",),
                                   timeout=5),
    "emulate-drive-cia402-node-200": Case(["emulate-drive", "--protocol", "cia402", "--node",
                                           "200"], mentions=("200",), timeout=5),
    "emulate-drive-unknown-interface": Case(["emulate-drive", "--interface", "nope"],
                                            mentions=("nope",), timeout=5),
    "emulate-drive-unknown-protocol": Case(["emulate-drive", "--protocol", "canopen-fd"],
                                           usage=True, timeout=5),
    "version": Case(["--version"], expect="ok"),
    "quiet-after-subcommand": Case(["check", GOOD, "-q"], expect="ok"),
    "verbose-after-subcommand": Case(["check", GOOD, "-v"], expect="ok"),
    "debug-after-subcommand": Case(["check", GOOD, "--debug"], expect="ok"),
    "quiet-after-run": Case(["run", GOOD, "--out", "out", "-q"], expect="ok"),
}


@pytest.mark.parametrize("case", [pytest.param(c, id=k) for k, c in CASES.items()])
def test_hostile_command_line(case: Case, cwd: Path) -> None:
    o = run_cli(case.args, cwd, timeout=case.timeout, watched=[cwd.parent])
    if case.expect == "ok":
        assert_ok(o)
    else:
        assert_clean_error(o, fix=case.fix, mentions=case.mentions, usage=case.usage)
        # a refused command leaves no file behind
        assert_writes_only_under(o, [])


def test_version_names_the_package(cwd: Path) -> None:
    o = run_cli(["--version"], cwd)
    assert_ok(o)
    assert "twmr-cosim" in o.stdout + o.stderr, o.describe()


def test_quiet_run_prints_nothing_on_success(cwd: Path) -> None:
    o = run_cli(["run", GOOD, "--out", "out", "-q"], cwd)
    assert_ok(o)
    assert o.stderr.strip() == "", f"-q after the subcommand did not quiet the run\n{o.describe()}"


def test_verbose_after_subcommand_adds_messages(cwd: Path) -> None:
    quiet = run_cli(["run", GOOD, "--out", "a", "-q"], cwd)
    verbose = run_cli(["run", GOOD, "--out", "b", "-v"], cwd)
    assert_ok(quiet)
    assert_ok(verbose)
    assert len(verbose.stderr) > len(quiet.stderr), verbose.describe()


def test_debug_on_a_bad_scenario_shows_the_traceback(cwd: Path) -> None:
    write(cwd, "bad.yaml", GOOD_TEXT.replace("kind: gain", "kind: gian"))
    o = run_cli(["check", "bad.yaml", "--debug"], cwd)
    assert o.returncode > 0, o.describe()
    assert "Traceback" in o.stderr, f"--debug did not show the traceback\n{o.describe()}"
    assert "gian" in o.stderr, o.describe()


# -- replay on a real frame log ---------------------------------------------------------------
def test_replay_odrive_log_decodes(odrive_log: Path, cwd: Path) -> None:
    o = run_cli(["replay", str(odrive_log)], cwd)
    assert_ok(o)
    assert len(o.stdout.splitlines()) > 1, o.describe()


def test_replay_cia402_on_an_odrive_log(odrive_log: Path, cwd: Path) -> None:
    o = run_cli(["replay", "--protocol", "cia402", str(odrive_log)], cwd)
    assert_clean_error(o, mentions=("cia402",))


def test_replay_out_in_a_missing_folder(odrive_log: Path, cwd: Path) -> None:
    o = run_cli(["replay", str(odrive_log), "--out", "nodir/frames.csv"], cwd,
                watched=[cwd.parent])
    assert_clean_error(o, mentions=("nodir",))
    assert_writes_only_under(o, [])


# -- closed and broken output ------------------------------------------------------------------
def _no_broken_pipe_noise(o: Outcome) -> None:
    assert_no_traceback(o)
    assert "BrokenPipeError" not in o.stderr, o.describe()
    assert "Exception ignored" not in o.stderr, o.describe()
    assert o.stdout.strip(), f"nothing reached the pipe\n{o.describe()}"


PIPES: dict[str, Callable[[Path], str]] = {
    "components-into-head": lambda log: "twmr components | head -1",
    "check-into-head": lambda log: f"twmr check {GOOD} | head -1",
    "check-schedule-into-head": lambda log: f"twmr check {GOOD} --schedule | head -1",
    "replay-into-head": lambda log: f"twmr replay '{log}' | head -1",
}


@pytest.mark.parametrize("make", [pytest.param(m, id=k) for k, m in PIPES.items()])
def test_closed_stdout_pipe(make: Callable[[Path], str], odrive_log: Path, cwd: Path) -> None:
    o = run_shell(make(odrive_log), cwd, timeout=30)
    _no_broken_pipe_noise(o)


def test_stdout_closed(cwd: Path) -> None:
    o = run_shell(f"twmr check {GOOD} >&-", cwd, timeout=30)
    assert_no_traceback(o)
    if o.returncode != 0:
        assert_clean_error(o)


def test_stdout_is_a_full_disk(cwd: Path) -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    o = run_shell("twmr components > /dev/full", cwd, timeout=30)
    assert_clean_error(o)
