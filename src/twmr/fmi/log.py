"""`FmuLog`: an FMU's log messages, captured through the FMI logger callback.

The last lines are kept for the error of a failed call (`FmuError` carries them); every message
also goes to the `twmr.fmu` logger: warnings and errors at WARNING, the rest at DEBUG, or all at
INFO when the run shows the whole log (`twmr run --fmu-log`).
"""
from __future__ import annotations

import collections
import logging
from typing import Any

log = logging.getLogger("twmr.fmu")
_STATUS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")
#: lines kept for error messages
KEEP = 20
#: set by `twmr run --fmu-log`: every FMU message is shown (logged at INFO)
show_all = False


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

    def add(self, status: int, category: str, message: str) -> None:
        label = _STATUS[status] if 0 <= status < len(_STATUS) else str(status)
        line = f"[{label}] {category + ': ' if category else ''}{message.rstrip()}"
        self.lines.append(line)
        level = logging.INFO if show_all else (logging.WARNING if 0 < status < 5 and status != 2
                                               else logging.DEBUG)
        log.log(level, "FMU '%s' %s", self.instance, line)

    def tail(self) -> list[str]:
        return list(self.lines)

    def fmi2_callbacks(self) -> Any:
        """fmi2CallbackFunctions whose logger (behind fmpy's printf-formatting proxy) lands
        here."""
        from fmpy.fmi2 import (
            fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.fmi2 import calloc, free

        def logger(env: Any, name: Any, status: int, category: Any, message: Any) -> None:
            self.add(int(status), _text(category), _text(message))

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        from ctypes import byref

        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(byref(callbacks))
        except Exception:  # noqa: BLE001 - no proxy for this platform: messages unformatted
            pass
        self._keep.append((callbacks, logger))
        return callbacks

    def fmi3_logger(self) -> Any:
        """A Python function with fmi3LogMessageCallback's arguments."""
        def logger(env: Any, status: int, category: Any, message: Any) -> None:
            self.add(int(status), _text(category), _text(message))

        self._keep.append(logger)
        return logger
