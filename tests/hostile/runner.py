"""Shared runner of the hostile-input suite: the `twmr` command line in a subprocess, with a
memory cap, a timeout and a record of every file it created, modified or deleted.

The project's promise, checked by the helpers below: bad input gets a clear one-paragraph error
naming the file/line/component/port at fault and how to fix it (`Fix: ...`), never a traceback;
nothing already computed is lost; nothing is written outside the results folder; no hang; no
memory blow-up.
"""
from __future__ import annotations

import contextlib
import fnmatch
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pytest

MEMORY_CAP = 3 * 1024**3          # RLIMIT_AS of every child
RSS_LIMIT = 1024 * 1024**2        # "no memory blow-up": peak resident set of a child
MAX_ERROR_LINES = 8               # "at most a few lines"
ERROR_STARTS = ("error: ", "interrupted")
FORBIDDEN = ("Traceback", "Exception ignored")
SAFETY_NET = "cannot build the scenario ("   # the loader's catch-all: an internal bug

REPO = Path(__file__).resolve().parents[2]
LOOP = REPO / "tests" / "fixtures" / "scenarios" / "loop.yaml"
GOOD_TEXT = LOOP.read_text()
BENCH = REPO / "scenarios" / "bench_odrive_trajectory1.yaml"
PAPER = REPO / "scenarios" / "paper_trajectory1_asmc.yaml"

Snapshot = dict  # Path -> (kind, size, mtime_ns)


@dataclass
class Outcome:
    """What one `twmr` process did."""

    args: list[str]                   # as shown: twmr's arguments, or one shell command line
    cwd: Path
    returncode: int
    stdout: str
    stderr: str
    elapsed: float
    pid: int
    max_rss: int                      # bytes, peak resident set of the child
    created: set[Path] = field(default_factory=set)
    modified: set[Path] = field(default_factory=set)
    deleted: set[Path] = field(default_factory=set)
    shell: bool = False

    @property
    def changed(self) -> set[Path]:
        """Files (and new folders) created or modified."""
        return self.created | self.modified

    def describe(self) -> str:
        err = self.stderr if len(self.stderr) < 3000 else self.stderr[:1500] + "\n[...]\n" + \
            self.stderr[-1500:]
        out = self.stdout if len(self.stdout) < 1000 else self.stdout[:1000] + "\n[...]"
        command = self.args[0] if self.shell else "twmr " + " ".join(self.args)
        return (f"$ {command}   (cwd {self.cwd})\n"
                f"exit {self.returncode} after {self.elapsed:.2f} s, peak RSS "
                f"{self.max_rss / 2**20:.0f} MiB\n--- stderr ---\n{err}\n--- stdout ---\n{out}")


# -- snapshots ---------------------------------------------------------------------------------
def _real_parent(path: Path) -> Path:
    """`path` with its parent resolved but its last component kept (a symlink stays a link)."""
    path = Path(os.path.abspath(path))
    return Path(os.path.realpath(path.parent)) / path.name


def snapshot(folders: Iterable[Path]) -> Snapshot:
    """path -> (kind, size, mtime_ns) of everything under `folders` (symlinks not followed)."""
    snap: Snapshot = {}
    for root in folders:
        root = Path(os.path.realpath(root))
        if not root.is_dir():
            continue
        for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
            for name in dirnames + filenames:
                p = Path(dirpath) / name
                try:
                    st = os.lstat(p)
                except OSError:
                    continue
                if os.path.islink(p):
                    kind = "l"
                elif p.is_dir():
                    kind = "d"
                else:
                    kind = "f"
                snap[p] = (kind, st.st_size, st.st_mtime_ns)
    return snap


def diff(before: Snapshot, after: Snapshot) -> tuple[set[Path], set[Path], set[Path]]:
    """(created, modified, deleted); a folder counts only when it appears or disappears."""
    created = {p for p in after if p not in before}
    deleted = {p for p in before if p not in after}
    modified = {p for p in after if p in before and before[p] != after[p]
                and not (before[p][0] == after[p][0] == "d")}
    return created, modified, deleted


# -- running ---------------------------------------------------------------------------------
def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def _resident_peak(pid: int) -> int:
    """The peak resident set [bytes] of process `pid` so far (VmHWM of its own memory map, 0
    once it has ended). Not `wait4`'s ru_maxrss: a forked child starts with its parent's peak,
    which under pytest-xdist is the worker's hundreds of MiB. Sampled while the child runs; the
    memory cap (RLIMIT_AS) bounds what a sample could miss."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _run(argv: list[str], shown: list[str], cwd: Path, timeout: float, stdin: bytes | None,
         watched: Sequence[Path], env: dict[str, str] | None, shell: bool = False) -> Outcome:
    cwd = Path(cwd)
    roots = [cwd, *[Path(w) for w in watched]]
    before = snapshot(roots)
    with tempfile.TemporaryDirectory(prefix="twmr-hostile-io-") as io_dir:
        io = Path(io_dir)
        stdin_file = io / "stdin"
        stdin_file.write_bytes(stdin or b"")
        environment = dict(os.environ if env is None else env)
        environment.setdefault("MPLBACKEND", "Agg")
        environment.pop("PYTHONSTARTUP", None)
        with open(stdin_file, "rb") as fin, open(io / "stdout", "wb") as fout, \
                open(io / "stderr", "wb") as ferr:
            t0 = time.perf_counter()
            proc = subprocess.Popen(argv, cwd=cwd, stdin=fin, stdout=fout, stderr=ferr,
                                    env=environment, preexec_fn=_limits, start_new_session=True)
            status, peak = None, 0
            while True:
                peak = max(peak, _resident_peak(proc.pid))
                pid, st, _ = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    status = st
                    break
                if time.perf_counter() - t0 > timeout:
                    break
                time.sleep(0.01)
            elapsed = time.perf_counter() - t0
            if status is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                _, _, ru = os.wait4(proc.pid, 0)
                proc.returncode = -9
                err = (io / "stderr").read_bytes().decode(errors="replace")
                command = shown[0] if shell else "twmr " + " ".join(shown)
                pytest.fail(f"hang: `{command}` (cwd {cwd}) did not finish within "
                            f"{timeout:g} s (peak RSS {ru.ru_maxrss / 1024:.0f} MiB); stderr so "
                            f"far:\n{err[-2000:]}", pytrace=False)
            code = os.waitstatus_to_exitcode(status)
            proc.returncode = code
        stdout = (io / "stdout").read_bytes().decode(errors="replace")
        stderr = (io / "stderr").read_bytes().decode(errors="replace")
    created, modified, deleted = diff(before, snapshot(roots))
    return Outcome(list(shown), cwd, code, stdout, stderr, elapsed, proc.pid,
                   peak, created, modified, deleted, shell)


def run_cli(args: Sequence[str], cwd: Path, timeout: float = 60, stdin: bytes | None = None,
            watched: Sequence[Path] = (), env: dict[str, str] | None = None) -> Outcome:
    """`python -m twmr.cli *args` in `cwd` (a fresh temp folder), capped at 3 GiB of address
    space; a run longer than `timeout` seconds is killed and fails the test as a "hang".
    `watched`: more folders whose files are snapshot before and after."""
    args = [str(a) for a in args]
    return _run([sys.executable, "-m", "twmr.cli", *args], args, cwd, timeout, stdin, watched,
                env)


def run_shell(command: str, cwd: Path, timeout: float = 60,
              watched: Sequence[Path] = ()) -> Outcome:
    """A shell pipeline (bash, no pipefail) where `twmr` means this interpreter's CLI."""
    twmr = f"'{sys.executable}' -m twmr.cli"
    script = command.replace("twmr ", twmr + " ", 1) if command.startswith("twmr ") else command
    script = script.replace("| twmr ", f"| {twmr} ")
    return _run(["bash", "-c", script], [command], cwd, timeout, None, watched, None, shell=True)


# -- assertions --------------------------------------------------------------------------------
def _lines(text: str) -> list[str]:
    """Lines of a stream as a terminal shows them (a '\\r' rewrites the line: progress bars)."""
    return [line.rsplit("\r", 1)[-1] for line in text.split("\n")]


def error_paragraph(outcome: Outcome) -> list[str]:
    """The lines from the first 'error: ' / 'interrupted' line to the end of stderr."""
    lines = _lines(outcome.stderr.rstrip())
    for i, line in enumerate(lines):
        if line.startswith(ERROR_STARTS):
            return lines[i:]
    return []


def assert_no_traceback(outcome: Outcome) -> None:
    for stream in (outcome.stderr, outcome.stdout):
        for marker in FORBIDDEN:
            assert marker not in stream, f"{marker!r} printed:\n{outcome.describe()}"


def assert_bounded(outcome: Outcome, rss_limit: int = RSS_LIMIT) -> None:
    """Not killed by a signal, no MemoryError, peak RSS under the limit."""
    assert outcome.returncode >= 0, \
        f"crashed: killed by signal {-outcome.returncode}\n{outcome.describe()}"
    assert "MemoryError" not in outcome.stderr, f"memory: MemoryError\n{outcome.describe()}"
    assert outcome.max_rss <= rss_limit, (f"memory: peak RSS {outcome.max_rss / 2**20:.0f} MiB "
                                          f"> {rss_limit / 2**20:.0f} MiB\n{outcome.describe()}")


def assert_clean_error(outcome: Outcome, *, fix: bool = True, mentions: Sequence[str] = (),
                       usage: bool = False, rss_limit: int = RSS_LIMIT) -> list[str]:
    """Non-zero exit, no traceback, and stderr ends in ONE paragraph (no blank line, at most
    MAX_ERROR_LINES lines) that starts with 'error: ' or 'interrupted' and holds 'Fix:'
    (`fix=False` relaxes that for the case) and every string of `mentions`.

    `usage=True` accepts argparse's own usage error instead ('usage: ...' then
    'twmr ...: error: ...', exit 2) for mistakes in the command line itself; it never holds
    'Fix:' (argparse prints the usage as the fix), so it implies fix=False, and the line limit
    applies from its 'error:' line on (the usage synopsis is argparse's, however long).
    Returns the paragraph's lines."""
    assert_bounded(outcome, rss_limit)
    assert outcome.returncode != 0, f"exit status 0 for bad input\n{outcome.describe()}"
    assert outcome.stderr.strip(), f"nothing on stderr\n{outcome.describe()}"
    assert_no_traceback(outcome)
    if usage and outcome.returncode == 2 and outcome.stderr.lstrip().startswith("usage:"):
        para = _lines(outcome.stderr.strip())
        assert all(line.strip() for line in para), \
            f"the error is more than one paragraph (blank line inside)\n{outcome.describe()}"
        at = [i for i, line in enumerate(para) if ": error: " in line]
        assert at, outcome.describe()
        para = para[at[0]:]
        fix = False
    else:
        para = error_paragraph(outcome)
        assert para, (f"stderr has no line starting with 'error: ' or 'interrupted'\n"
                      f"{outcome.describe()}")
    assert all(line.strip() for line in para), \
        f"the error is more than one paragraph (blank line inside)\n{outcome.describe()}"
    assert len(para) <= MAX_ERROR_LINES, \
        f"the error is {len(para)} lines long (> {MAX_ERROR_LINES})\n{outcome.describe()}"
    text = "\n".join(para)
    assert SAFETY_NET not in text, \
        f"the loader's catch-all answered (an internal error, no real fix)\n{outcome.describe()}"
    if fix:
        assert "Fix:" in text, f"the error says no 'Fix:'\n{outcome.describe()}"
    for m in mentions:
        assert m in text, f"the error does not name {m!r}\n{outcome.describe()}"
    return para


def assert_ok(outcome: Outcome, rss_limit: int = RSS_LIMIT) -> None:
    """Exit 0, no traceback, bounded memory."""
    assert_bounded(outcome, rss_limit)
    assert outcome.returncode == 0, f"expected success\n{outcome.describe()}"
    assert_no_traceback(outcome)


def assert_ok_or_clean_error(outcome: Outcome, **kw: object) -> None:
    """Either it works, or it is refused with a clean error."""
    if outcome.returncode == 0:
        assert_ok(outcome)
    else:
        assert_clean_error(outcome, **kw)  # type: ignore[arg-type]


def _matches(p: Path, allowed: Path | str) -> bool:
    text = str(allowed)
    if any(ch in text for ch in "*?["):
        pattern = str(_real_parent(Path(text)))
        return any(fnmatch.fnmatchcase(str(q), pattern) for q in (p, *p.parents))
    a = _real_parent(Path(text))
    return p == a or a in p.parents


def assert_writes_only_under(outcome: Outcome, allowed_folders: Iterable[Path | str]) -> None:
    """Every file created, modified or deleted (in the watched folders) lies in one of
    `allowed_folders` (a path, or a glob like 'out.partial-*'); a new folder is also allowed
    when it is an ancestor of an allowed folder (`results/` for `results/x`)."""
    allowed = list(allowed_folders)
    ancestors = {q for a in allowed if not any(ch in str(a) for ch in "*?[")
                 for q in _real_parent(Path(a)).parents}
    bad = []
    for p in sorted(outcome.created | outcome.modified | outcome.deleted):
        if any(_matches(p, a) for a in allowed):
            continue
        if p in outcome.created and p in ancestors and p.is_dir():
            continue
        how = "created" if p in outcome.created else "modified" if p in outcome.modified \
            else "deleted"
        bad.append(f"{how}: {p}")
    assert not bad, ("written outside " + ", ".join(str(a) for a in allowed) + ":\n  " +
                     "\n  ".join(bad[:20]) + f"\n{outcome.describe()}")


def result_family(out: Path) -> list[Path | str]:
    """A run's folder and the siblings it may use: `out.incomplete`, `out.partial-<pid>`."""
    out = _real_parent(Path(out))
    return [out, out.with_name(out.name + ".incomplete"), str(out) + ".partial-*"]


def write(folder: Path, name: str, content: str | bytes) -> Path:
    """A file in `folder` (text written as UTF-8)."""
    path = Path(folder) / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


def root_can_write(folder: Path) -> bool:
    """True when this process can write into `folder` despite its mode (running as root)."""
    probe = Path(folder) / ".probe-write"
    try:
        probe.write_text("x")
    except OSError:
        return False
    probe.unlink()
    return True
