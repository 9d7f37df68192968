"""`SweepFolder`: the folder of one sweep — its lock, its rows and what identifies them.

- One writer at a time: `DIR/.lock` is held (`flock`) while a sweep runs; a second sweep into the
  folder is refused, naming the holder (pid, host, start time). The kernel releases the lock of a
  process that dies; its record is then taken over, with a message.
- Every row carries `sweep_id`, a hash of the scenario's text, the `--set` overrides and the metric
  selection. A folder is identified by its rows, not by `sweep.json` (a description for the report
  and for messages): rows of another sweep, rows without `sweep_id`, an unreadable table or journal
  and files that are not a sweep's are refused before anything runs.
- Each finished run's row is appended to `DIR/runs.jsonl` (flushed); `runs.parquet` is written
  whole from every row, then renamed, and the journal removed.
"""
from __future__ import annotations

import contextlib
import datetime
import fcntl
import hashlib
import json
import logging
import os
import socket
from pathlib import Path
from typing import IO, Any

from twmr.sweeps.spec import SweepError, SweepSpec

log = logging.getLogger("twmr.sweep")
JOURNAL, TABLE, DESCRIPTION, LOCK = "runs.jsonl", "runs.parquet", "sweep.json", ".lock"
#: entries of a sweep folder besides the above: kept signals, the report
_OURS = {JOURNAL, TABLE, DESCRIPTION, LOCK, "runs", "report"}
IDENTITY = "sweep_id"


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def identity(spec: SweepSpec, content: str) -> dict[str, Any]:
    """What makes runs comparable: the scenario's text (its hash), the overrides given to every
    run and the metric selection, with `sweep_id`, their hash (16 hex digits)."""
    ident: dict[str, Any] = {"scenario_sha256": _digest(content), "set": list(spec.fixed),
                             "metrics": list(spec.metrics)}
    ident[IDENTITY] = _digest(json.dumps(ident, sort_keys=True))[:16]
    return ident


_WHAT = {"scenario_sha256": "another scenario (or another version of its file)",
         "set": "other --set overrides", "metrics": "other --metrics"}


class SweepFolder:
    """The folder `path` of the sweep `spec` of a scenario of text `content`, as a context:
    entering checks and locks it and reads the `rows` already there; leaving releases it."""

    def __init__(self, path: Path, spec: SweepSpec, content: str):
        self.path = path
        self.spec = spec
        self.ident = identity(spec, content)
        self.rows: list[dict[str, Any]] = []
        self._lock: IO[str] | None = None

    def __enter__(self) -> SweepFolder:
        self.rows = self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def sweep_id(self) -> str:
        return str(self.ident[IDENTITY])

    def open(self) -> list[dict[str, Any]]:
        """Lock the folder (created if needed), check that it holds only this sweep's rows,
        describe the sweep in sweep.json; the rows already done (table, then journal)."""
        self._refuse_foreign()
        self.path.mkdir(parents=True, exist_ok=True)
        self._take_lock()
        try:
            described = self._description()
            rows = self._read_rows()
            for row in rows:
                if row.get(IDENTITY) != self.sweep_id:
                    self._refuse_other(described, row)
            if described is not None and described.get(IDENTITY) != self.sweep_id and not rows:
                self._refuse_other(described, {})
            self._describe()
        except BaseException:
            self.close()
            raise
        return rows

    def close(self) -> None:
        """Release the lock (its record emptied: a clean end)."""
        if self._lock is None:
            return
        release_lock(self._lock)
        self._lock = None

    # -- the lock ------------------------------------------------------------------------------
    def _take_lock(self) -> None:
        self._lock = take_lock(self.path, "sweep")

    # -- identity ------------------------------------------------------------------------------
    def _refuse_foreign(self) -> None:
        """A folder holding anything but a sweep's files is not overwritten."""
        if self.path.is_symlink() or (self.path.exists() and not self.path.is_dir()):
            raise SweepError(f"{self.path} is not a folder (a file or a symbolic link). Fix: "
                             f"give a new or empty folder as --out.")
        if not self.path.exists():
            return
        foreign = sorted(e.name for e in self.path.iterdir() if e.name not in _OURS and not (
            e.name.startswith(".") and e.name.endswith((".part", ".tmp"))))
        if foreign:
            raise SweepError(f"{self.path} holds files that are not a sweep's "
                             f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); "
                             f"a sweep would write among them. Fix: give a new or empty folder "
                             f"as --out.")

    def _description(self) -> dict[str, Any] | None:
        """sweep.json as written by a sweep, or None when there is none; SweepError when it is
        not one a sweep wrote."""
        path = self.path / DESCRIPTION
        if not path.exists():
            return None
        try:
            described = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            described = None
        if not isinstance(described, dict) or not isinstance(described.get(IDENTITY), str):
            if self._has_rows():
                return None  # the rows say which sweep this is; sweep.json is rewritten
            raise SweepError(f"{path} is not a description written by `twmr sweep`. Fix: give "
                             f"another --out, or remove that file if the folder is yours.")
        return described

    def _has_rows(self) -> bool:
        return (self.path / TABLE).exists() or (self.path / JOURNAL).exists()

    def _refuse_other(self, described: dict[str, Any] | None, row: dict[str, Any]) -> None:
        """SweepError: the folder holds another sweep's runs (or rows of unknown origin), with
        what differs when sweep.json describes them."""
        found = row.get(IDENTITY) if row else (described or {}).get(IDENTITY)
        if described and described.get(IDENTITY) == found:
            for key, what in _WHAT.items():
                if key in described and described[key] != self.ident[key]:
                    raise SweepError(f"{self.path} holds a sweep of {what} ({key}: "
                                     f"{described[key]!r}, now {self.ident[key]!r}); its runs "
                                     f"would be mixed with these. Fix: give another --out, or "
                                     f"the same {key.split('_')[0]} as before.")
        origin = f"of another sweep ({IDENTITY} {found!r}, this one is {self.sweep_id!r}: " \
                 f"another scenario, --set or --metrics)" if isinstance(found, str) else \
            f"without a {IDENTITY} (not written by this version of `twmr sweep`)"
        raise SweepError(f"{self.path} holds runs {origin}; they would be mixed with these. "
                         f"Fix: give another --out.")

    def _describe(self) -> None:
        """sweep.json: what the folder's runs vary and how they were drawn (written whole, then
        renamed)."""
        spec = self.spec
        described = {"scenario": spec.scenario, **self.ident,
                     "vary": {v.name: v.text for v in spec.vary}, "samples": spec.samples,
                     "method": spec.method, "seed": spec.seed}
        partial = self.path / f".{DESCRIPTION}.{os.getpid()}.tmp"
        partial.write_text(json.dumps(described, indent=2) + "\n")
        os.replace(partial, self.path / DESCRIPTION)

    # -- rows ----------------------------------------------------------------------------------
    def _read_rows(self) -> list[dict[str, Any]]:
        """Rows already in the folder: runs.parquet, then the journal a killed sweep left (its
        last line may be cut short). SweepError for a table or journal a sweep did not write."""
        rows: dict[str, dict[str, Any]] = {}
        table = self.path / TABLE
        if table.exists():
            import pyarrow.parquet as pq

            try:
                listed = pq.read_table(table).to_pylist()
            except Exception as err:  # noqa: BLE001 - any unreadable table is refused plainly
                raise SweepError(f"{table} cannot be read ({type(err).__name__}: "
                                 f"{str(err).splitlines()[0] if str(err) else ''}). Fix: give "
                                 f"another --out, or move that file aside.") from None
            for row in listed:
                rows[self._checked(row, table)] = row
        journal = self.path / JOURNAL
        if journal.exists():
            lines = journal.read_text(encoding="utf-8", errors="replace").split("\n")
            for number, line in enumerate(lines, 1):
                try:
                    row = json.loads(line)
                except ValueError:
                    if number >= len(lines) - 1:
                        continue  # the line being written when the sweep was killed
                    row = None
                rows[self._checked(row, journal, number)] = row
        return list(rows.values())

    def _checked(self, row: Any, where: Path, line: int = 0) -> str:
        """The run id of a row read back; SweepError when it is not a sweep's row."""
        if isinstance(row, dict) and isinstance(row.get("run_id"), str) and "status" in row:
            return row["run_id"]
        at = f"{where}:{line}" if line else str(where)
        raise SweepError(f"{at}: not a row written by `twmr sweep` (each has a run_id and a "
                         f"status). Fix: give another --out, or move that file aside.")


def take_lock(path: Path, what: str) -> IO[str]:
    """Hold `path/.lock` (`flock`, released by the kernel when the process dies) with a record
    of the holder; a SweepError naming the holder when another `what` (sweep, tune) has it."""
    lock = open(path / LOCK, "a+", encoding="utf-8")  # noqa: SIM115 - held by the caller
    try:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = _holder(lock)
        lock.close()
        raise SweepError(f"{path} is in use by another {what} ({holder}); two of them "
                         f"writing one folder would lose each other's rows. Fix: wait for "
                         f"it to end, or give another --out.") from None
    left = _holder(lock)
    if left:
        log.warning("taking over the lock of %s left by a %s that no longer runs (%s)",
                    path, what, left)
    started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    lock.seek(0)
    lock.truncate(0)
    lock.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                           "started": started}) + "\n")
    lock.flush()
    return lock


def release_lock(lock: IO[str]) -> None:
    """Release a lock of `take_lock`, its record emptied (a clean end)."""
    with contextlib.suppress(OSError):
        lock.truncate(0)
        lock.flush()
    lock.close()


def open_journal(path: Path) -> IO[str]:
    """The journal at `path` opened to append, a last line cut short by a kill removed first:
    an append never lands on a fragment, so every resume reads every finished row."""
    with contextlib.suppress(FileNotFoundError), open(path, "r+b") as f:
        data = f.read()
        if data and not data.endswith(b"\n"):
            f.truncate(data.rfind(b"\n") + 1)
    return open(path, "a", encoding="utf-8")  # noqa: SIM115 - closed by the caller


def append_row(journal: IO[str], row: dict[str, Any]) -> None:
    """A finished run's row into the journal, flushed (a killed sweep keeps it)."""
    journal.write(json.dumps(row, default=_plain) + "\n")
    journal.flush()


def write_table(rows: list[dict[str, Any]], folder: Path) -> Path:
    """runs.parquet from `rows` in sample order (written whole, then renamed); the journal is
    then removed. Built by pyarrow alone (`twmr.sweeps.table`) unless a column holds other
    values than it builds: then by pandas."""
    import pyarrow.parquet as pq

    from twmr.sweeps.table import arrow_table

    ordered = sorted(rows, key=lambda r: (r.get("sample") is None, r.get("sample") or 0))
    table = arrow_table(ordered, list(dict.fromkeys(k for row in rows for k in row)))
    target = folder / TABLE
    partial = folder / f".{TABLE}.{os.getpid()}.part"
    if table is not None:
        pq.write_table(table, partial)
    else:
        import pandas as pd

        pd.DataFrame(ordered).to_parquet(partial, index=False)
    os.replace(partial, target)
    (folder / JOURNAL).unlink(missing_ok=True)
    return target


def _holder(lock: IO[str]) -> str:
    """'pid P on HOST, started T' from a lock's record ('' when it is empty)."""
    lock.seek(0)
    text = lock.read(4096).strip()
    if not text:
        return ""
    try:
        info = json.loads(text)
        return f"pid {info['pid']} on {info['host']}, started {info['started']}"
    except (ValueError, KeyError, TypeError):
        return f"its record reads {text[:80]!r}"


def _plain(value: Any) -> Any:
    """JSON for numpy scalars and tuples in rows."""
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return str(value)
