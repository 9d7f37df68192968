"""The error tree. Every failure a user can cause is a `CosimError` with a one-paragraph message.

Messages name the file and line, the component and port at fault, and say how to fix it.
The CLI prints `str(error)` without a traceback.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Location:
    """A place in a scenario file: file name, 1-based line (0 when unknown) and the key path."""

    file: str = "<scenario>"
    line: int = 0
    path: str = ""

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{where} ({self.path})" if self.path else where


class CosimError(Exception):
    """Base of every error the engine reports to a user. Every subclass pickles (sweeps send
    errors across processes): `__reduce__` rebuilds it from its constructor arguments."""

    def __reduce__(self) -> tuple:
        return (type(self), self.args)


class UnitError(CosimError):
    """A unit string that cannot be parsed, or two units that cannot be converted."""


@dataclass(frozen=True)
class Problem:
    """One problem found in a scenario, with where it is and how to fix it."""

    location: Location
    message: str
    hint: str = ""

    def __str__(self) -> str:
        text = f"{self.location}: {self.message}"
        return f"{text} Fix: {self.hint}" if self.hint else text


class ScenarioError(CosimError):
    """A scenario file with one or more problems; every problem found is listed."""

    def __init__(self, problems: list[Problem] | Problem):
        self.problems = [problems] if isinstance(problems, Problem) else list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))

    def __reduce__(self) -> tuple:
        return (type(self), (self.problems,))


class WiringError(ScenarioError):
    """Ports that cannot be connected as asked (sizes, types, units, drivers)."""


class AlgebraicLoopError(WiringError):
    """A cycle of direct-feedthrough connections; the message prints the cycle."""


class ComponentError(CosimError):
    """A component that raised, or produced NaN/Inf, while the system ran."""

    def __init__(self, instance: str, time: float | None, message: str):
        self.instance = instance
        self.time = time
        self.message = message
        at = f" at t = {time:.9g} s" if time is not None else ""
        super().__init__(f"component '{instance}'{at}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.instance, self.time, self.message))


class FmuError(ComponentError):
    """An FMU that cannot be loaded, or whose FMI call returned an error status; `log` holds the
    FMU's last log lines, printed under the message."""

    def __init__(self, instance: str, time: float | None, message: str,
                 log: tuple[str, ...] | list[str] = ()):
        self.log = tuple(log)
        text = message
        if self.log:
            text += "\n  FMU log (last lines):\n" + "\n".join(f"    {line}" for line in self.log)
        super().__init__(instance, time, text)
        self.message = message

    def __reduce__(self) -> tuple:
        return (type(self), (self.instance, self.time, self.message, self.log))


class FmuTerminated(FmuError):
    """An FMU asked to end the simulation (terminateSimulation): a failure, or with
    `experiment.fmu_terminate: stop` the normal end of the run at `time`."""

    FIX = " Fix: to end the run normally there instead, set 'experiment.fmu_terminate: stop'."

    def __init__(self, instance: str, time: float | None, message: str,
                 log: tuple[str, ...] | list[str] = ()):
        if not message.endswith(self.FIX):
            message += self.FIX
        super().__init__(instance, time, message, log)


class HardwareError(ComponentError):
    """A hardware fault: lost heartbeat, EMCY, bus-off, watchdog, or a python-can error."""
