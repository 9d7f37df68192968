"""`FmuLog`: an FMU's log messages, captured through the FMI logger callback.

The last lines are kept for the error of a failed call (`FmuError` carries them); every message
also goes to the `twmr.fmu` logger: warnings and errors at WARNING, the rest at DEBUG, or all at
INFO when the run shows the whole log (`twmr run --fmu-log`).
"""
from __future__ import annotations

import collections
import contextlib
import itertools
import logging
import weakref
from collections.abc import Iterator
from typing import Any

log = logging.getLogger("twmr.fmu")
_STATUS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")
#: lines kept for error messages
KEEP = 20

_keys = itertools.count(1)
_by_key: dict[int, weakref.ref[FmuLog]] = {}
_logger: list[Any] = []


def _dispatch(env: Any, name: Any, status: int, category: Any, message: Any) -> None:
    """The one Python FMI 2.0 logger of the process: to the FmuLog whose key is the instance's
    componentEnvironment; others (fmpy's own default callbacks) are printed as fmpy does."""
    ref = _by_key.get(env or 0)
    log_ = ref() if ref is not None else None
    if log_ is None:
        from fmpy.fmi2 import printLogMessage

        printLogMessage(env, name, status, category, message)
        return
    log_.add(int(status), _text(category), _text(message))


def _fmi2_logger() -> Any:
    """The logger every FmuLog hands its FMI 2.0 FMUs: fmpy's native proxy, which formats the
    printf-style arguments ctypes cannot pass and calls `_dispatch`. The proxy keeps a single,
    process-wide target, so it is pointed at `_dispatch` once and for the life of the process
    (a per-instance target would dangle once that instance is gone)."""
    if not _logger:
        from ctypes import byref

        from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        target = fmi2CallbackLoggerTYPE(_dispatch)
        holder = fmi2CallbackFunctions()
        holder.logger = target
        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(byref(holder))
        except Exception:  # noqa: BLE001 - no proxy for this platform: messages unformatted
            pass
        _logger.extend([target, holder, holder.logger])
    return _logger[2]


def _text(raw: Any) -> str:
    if raw is None:
        return ""
    return raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)


class FmuLog:
    """Collects one FMU instance's messages; `fmi2_callbacks()` / `fmi3_logger()` are passed
    to instantiate."""

    def __init__(self, instance: str):
        self.instance = instance
        self.lines: collections.deque[str] = collections.deque(maxlen=KEEP)
        self._keep: list[Any] = []  # ctypes callbacks must outlive the instance
        self.probing = False  # a call whose refusal is expected: its messages at DEBUG
        self.show_all = False  # every message at INFO (`Options.fmu_log`)

    @contextlib.contextmanager
    def probe(self) -> Iterator[None]:
        """Within: a call the FMU may refuse without harm (its messages kept at DEBUG)."""
        self.probing = True
        try:
            yield
        finally:
            self.probing = False

    def add(self, status: int, category: str, message: str) -> None:
        label = _STATUS[status] if 0 <= status < len(_STATUS) else str(status)
        line = f"[{label}] {category + ': ' if category else ''}{message.rstrip()}"
        self.lines.append(line)
        warns = 0 < status < 5 and status != 2 and not self.probing
        level = logging.INFO if self.show_all else (logging.WARNING if warns else logging.DEBUG)
        log.log(level, "FMU '%s' %s", self.instance, line)

    def tail(self) -> list[str]:
        return list(self.lines)

    def fmi2_callbacks(self) -> Any:
        """fmi2CallbackFunctions whose logger lands here (see `_fmi2_logger`)."""
        from ctypes import c_void_p

        from fmpy.fmi2 import (
            calloc,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            free,
        )

        key = next(_keys)
        _by_key[key] = weakref.ref(self)
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _fmi2_logger()
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        callbacks.componentEnvironment = c_void_p(key)
        self._keep.append(callbacks)
        return callbacks

    def fmi3_logger(self) -> Any:
        """A Python function with fmi3LogMessageCallback's arguments."""
        def logger(env: Any, status: int, category: Any, message: Any) -> None:
            self.add(int(status), _text(category), _text(message))

        self._keep.append(logger)
        return logger
