"""Warnings told once: per run (a `logging.Filter` on the `twmr` logger that passes the first of
each kind of warning and counts the rest) and per sweep (a worker takes its run's warnings into
the run's row; the collecting process tells each kind once, with the number of runs that gave it).

Two warnings are of one kind when their texts differ only in numbers (times, values, counts).
"""
from __future__ import annotations

import contextlib
import logging
import re
from collections.abc import Iterator
from dataclasses import dataclass, field

#: a number standing alone (not part of a name such as motor2)
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w])")


def kind_of(message: str) -> str:
    """The warning's text with every number replaced by '#'."""
    return _NUMBER.sub("#", message)


class OncePerRun(logging.Filter):
    """Between `attach()` and `detach()`, passes the first warning (or worse) of each kind of the
    `twmr` loggers to the handlers that would show it (`twmr`'s, the root's, or logging's last
    resort); `repeats` counts the ones held back, and `detach()` says how many there were."""

    def __init__(self) -> None:
        super().__init__()
        self.repeats: dict[str, int] = {}
        self._handlers: list[logging.Handler] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING or not record.name.startswith("twmr"):
            return True
        shown = getattr(record, "twmr_shown", None)  # judged once, whatever the handlers
        if shown is None:
            kind = kind_of(record.getMessage())
            shown = kind not in self.repeats
            self.repeats[kind] = self.repeats.get(kind, -1) + 1
            record.twmr_shown = shown
        return bool(shown)

    def attach(self) -> OncePerRun:
        root, last = logging.getLogger().handlers, logging.lastResort
        self._handlers = [*logging.getLogger("twmr").handlers, *root, *([last] if last else [])]
        for handler in self._handlers:
            handler.addFilter(self)
        return self

    def detach(self) -> None:
        for handler in self._handlers:
            handler.removeFilter(self)
        self._handlers = []
        held = sum(self.repeats.values())
        if held:
            logging.getLogger("twmr.run").warning(
                "(%d more warning(s) like those above were not shown)", held,
                extra={"twmr_held_back": True})


class _Taking(logging.Handler):
    def __init__(self, into: list[str]) -> None:
        super().__init__(logging.WARNING)
        self.into = into

    def emit(self, record: logging.LogRecord) -> None:
        if not getattr(record, "twmr_held_back", False):  # a sweep counts repeats itself
            self.into.append(record.getMessage())


@contextlib.contextmanager
def taken(into: list[str]) -> Iterator[None]:
    """While the block runs, the `twmr` logger's warnings go into `into`, not to its handlers
    (a sweep worker hands them back with the run's row)."""
    logger = logging.getLogger("twmr")
    handlers, propagate = logger.handlers[:], logger.propagate
    logger.handlers[:] = [_Taking(into)]
    logger.propagate = False
    try:
        yield
    finally:
        logger.handlers[:] = handlers
        logger.propagate = propagate


@dataclass
class SweepWarnings:
    """The warnings of a sweep's runs: each kind logged once, when it first comes, naming the
    run; `close()` logs how many runs gave each kind that came more than once."""

    log: logging.Logger
    #: the table whose 'warnings' column holds each run's
    table: str = "runs.parquet"
    first: dict[str, str] = field(default_factory=dict)
    runs: dict[str, int] = field(default_factory=dict)

    def add(self, run_id: str, messages: list[str]) -> None:
        for kind in dict.fromkeys(kind_of(m) for m in messages):
            self.runs[kind] = self.runs.get(kind, 0) + 1
        for message in messages:
            kind = kind_of(message)
            if kind not in self.first:
                self.first[kind] = run_id
                self.log.warning("run %s: %s", run_id, message)

    def close(self) -> None:
        for kind, n in self.runs.items():
            if n > 1:
                self.log.warning("the warning of run %s above came in %d runs in all (the "
                                 "'warnings' column of %s has each run's)",
                                 self.first[kind], n, self.table)
