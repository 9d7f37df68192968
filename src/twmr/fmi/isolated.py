"""`IsolatedFmu`: an FMU run in a worker process of its own (``isolate: true`` under an FMU
component's parameters, with ``timeout:`` [s], default 10), so a crash, an exit() or a hang inside
the FMU ends the run with an `FmuError` instead of ending or freezing the whole process.

The ports, parameters and start values come from a `FmuComponent` built here, which only reads
modelDescription.xml; the FMU itself runs in a real `FmuComponent` in ``python -m
twmr.fmi.worker`` (see there for the protocol). Each life-cycle call is one message each way over
a Unix socket pair; a step sends the values of the wired inputs and gets back those of the outputs
the run reads. A call that does not answer within `timeout` kills the worker. The worker's
standard output and error go to this process's standard error. POSIX only (the socket is handed
over as a file descriptor).
"""
from __future__ import annotations

import contextlib
import math
import os
import pickle
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import FmuError
from twmr.core.run import RunContext
from twmr.fmi.fmu import FmuComponent
from twmr.fmi.worker import receive, send

#: the longest the worker may take to start: an interpreter, fmpy, reading the FMU [s]
START_TIMEOUT = 60.0
#: the longest `terminate()` waits for the FMU's terminate, then for the process to end [s]
TERMINATE_TIMEOUT = 5.0
#: method -> the call named in messages
_CALLS = {"create": "loading", "prepare": "prepare", "setup": "instantiation",
          "initialize": "initialization", "evaluate": "evaluate (get/set of inputs and outputs)",
          "do_step": "doStep", "get_state": "getFMUstate", "set_state": "setFMUstate",
          "release_state": "freeFMUstate", "event": "event mode (a held state event)",
          "next_event": "the next time event", "terminate": "terminate"}
_FIX = ("check the FMU's inputs and parameters at this time (the results up to it are saved), "
        "or report it to the FMU's vendor; anything the FMU printed is on standard error.")


class IsolatedFmu(Component):
    """An `FmuComponent` run in a worker process: the same ports, parameters and results."""

    kind = "fmu"
    generic_units = FmuComponent.generic_units
    state_attributes = ("_t",)

    def __init__(self, name: str = "", path: str | Path = "", timeout: float = 10.0,
                 **kwargs: Any):
        """`timeout`: the longest one call into the FMU may take [s]; `kwargs`: as for
        `FmuComponent` (interface, solver_step, parameter and start values)."""
        super().__init__(name)
        self._desc = FmuComponent(self.name, path, **kwargs)
        self.path = Path(path)
        try:
            self._timeout = float(timeout)
        except (TypeError, ValueError):
            self._timeout = math.nan
        if not self._timeout > 0:
            raise FmuError(self.name, None, f"timeout {timeout!r} is not positive. Fix: give "
                           f"the longest one FMU call may take in seconds, e.g. timeout: 10 "
                           f"(.inf: no limit)")
        self._kwargs = kwargs
        self.can_get_and_set_state = self._desc.can_get_and_set_state
        self.aliases = self._desc.aliases
        self.terminals = self._desc.terminals
        self._given: dict[str, Any] = {}  # set_parameter calls, replayed in the worker
        self.variables = dict(self._desc.variables)
        self.__dict__.update({n: self._desc.__dict__[n] for n in self.variables})
        self._inputs = tuple(self.inputs)  # sent at each step: the wired inputs
        self._outputs = tuple(self.outputs)  # got back: the outputs the run reads
        self._report: dict[str, Any] = {}
        self._proc: subprocess.Popen[bytes] | None = None
        self._conn: Connection | None = None
        self._poll = select.poll()
        self._tmp: str | None = None
        self._pending = False  # a call whose answer was not read (cut short by Ctrl-C)
        self._ended = "it was not started"
        self._t: float | None = None
        #: after a step: (its first state event, its early event, whether it repeats)
        self._met: tuple[float | None, float | None, bool] = (None, None, True)

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        return self._desc.check(given)

    @property
    def sizing_parameters(self) -> frozenset[str]:  # type: ignore[override]
        return self._desc.sizing_parameters

    def set_parameter(self, name: str, value: Any) -> None:
        self._desc.set_parameter(name, value)
        self.__dict__[name] = self._given[name] = self._desc.__dict__[name]
        if name in self.sizing_parameters:  # arrays resized: the description's ports again
            self.variables = dict(self._desc.variables)
            self.__dict__.update({n: self._desc.__dict__[n] for n in self.variables})

    def _settable(self) -> dict[str, Any]:
        return {n: self.__dict__[n] for n, v in self.variables.items()
                if v.kind in ("parameter", "input", "state")}

    # -- the worker ---------------------------------------------------------------------------
    def _start(self) -> None:
        self._tmp = tempfile.mkdtemp(prefix="twmr-isolated-")
        ours, theirs = socket.socketpair()
        # the worker imports as this process does; its temporary files go where they are removed
        env = dict(os.environ, TMPDIR=self._tmp, PYTHONPATH=os.pathsep.join(sys.path))
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-u", "-m", "twmr.fmi.worker", str(theirs.fileno()),
                 self._tmp, str(self.path)], pass_fds=(theirs.fileno(),), stdin=subprocess.PIPE,
                stdout=2, env=env, start_new_session=True)
        except OSError as exc:
            ours.close()
            self._end_worker(0.0)
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}': its worker process "
                           f"could not start ({exc}).") from None
        finally:
            theirs.close()
        self._conn = Connection(ours.detach())
        self._poll.register(self._conn.fileno(), select.POLLIN)
        self._ended = ""
        self._call("create", (self.name, str(self.path), self._kwargs, self._given),
                   max(self._timeout, START_TIMEOUT))

    def _call(self, method: str, args: tuple[Any, ...] = (), limit: float | None = None) -> Any:
        """`method` run by the worker with `args`, waiting at most `limit` (the timeout) [s]."""
        conn = self._conn
        what = _CALLS[method]
        if conn is None:
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}': {what} cannot run: "
                           f"its process is not running ({self._ended}).")
        request = pickle.dumps((method, args), pickle.HIGHEST_PROTOCOL)
        limit = self._timeout if limit is None else limit
        try:
            send(conn, request)
            self._pending = True
            reply = receive(conn, self._poll, limit)
            if reply is None:
                self._ended = f"it did not return within {limit:g} s"
                self._end_worker(0.0)
                raise FmuError(self.name, self._t, f"FMU '{self.path.name}' did not return "
                               f"within {limit:g} s from {what}; its process was killed. Fix: "
                               f"if the FMU is only slow, raise `timeout:` under the "
                               f"component's parameters; else {_FIX}")
            status, value = pickle.loads(reply)
        except (EOFError, OSError):
            raise self._died(what) from None
        except FmuError:
            raise
        except Exception:  # noqa: BLE001 - a frame or pickle the worker did not write
            self._ended = "it sent a reply that is not one"
            self._end_worker(0.0)
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}': its process sent "
                           f"something that is not a reply during {what} (the FMU wrote to "
                           f"the worker's socket?); the process was killed. Fix: {_FIX}"
                           ) from None
        self._pending = False
        if status == 0:
            return value
        if status == 1:
            raise value
        raise FmuError(self.name, self._t, f"FMU '{self.path.name}': {what} raised {value}. "
                       f"Fix: {_FIX}")

    def _died(self, what: str) -> FmuError:
        """The error for a worker gone during `what`, once it is reaped."""
        code = self._end_worker(TERMINATE_TIMEOUT)
        if code is not None and code < 0:
            try:
                how = f"crashed (signal {signal.Signals(-code).name})"
            except ValueError:
                how = f"crashed (signal {-code})"
            message = f"FMU '{self.path.name}' {how} during {what}; only its process ended."
        else:
            how = f"exited with status {code}"
            message = f"FMU '{self.path.name}': the FMU process {how} during {what}."
        self._ended = how
        return FmuError(self.name, self._t, f"{message} Fix: {_FIX}")

    def _end_worker(self, grace: float) -> int | None:
        """Close the pipe and the worker's lifeline, wait `grace` [s] for it to end, else kill it;
        remove its temporary folder. Returns its exit status (negative: the signal)."""
        proc, self._proc = self._proc, None
        if self._conn is not None:
            self._poll.unregister(self._conn.fileno())
            self._conn.close()
            self._conn = None
        code = None
        if proc is not None:
            if proc.stdin is not None:
                proc.stdin.close()
            try:
                code = proc.wait(grace)
            except subprocess.TimeoutExpired:
                proc.kill()
                code = proc.wait()
            with contextlib.suppress(OSError):  # what the FMU started, in the worker's group
                os.killpg(proc.pid, signal.SIGKILL)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None
        return code

    # -- life cycle ---------------------------------------------------------------------------
    def prepare(self, run: RunContext) -> None:
        wired, read = run.wired_inputs(self.name), run.read_outputs(self.name)
        self._inputs = tuple(n for n in self.inputs if wired is None or n in wired)
        self._outputs = tuple(n for n in self.outputs if read is None or n in read)
        if self._conn is None:
            self._start()
        self._call("prepare", (run.folder, run.step, run.paced, wired, read,
                               run.outputs_as_stepped, run.steps_retaken, run.fmu_log))

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self._t = start
        if self._conn is None:
            self._start()
        self._call("setup", (start, stop, self.hold_events))

    def initialize(self) -> None:
        outputs = self._call("initialize", (self._settable(), self._inputs, self._outputs))
        self.__dict__.update(outputs)

    def evaluate(self, t: float) -> None:
        self._t = t
        d = self.__dict__
        values = self._call("evaluate", (t, tuple([d[n] for n in self._inputs])))
        d.update(zip(self._outputs, values, strict=False))

    def do_step(self, t: float, h: float) -> None:
        self._t = t
        d = self.__dict__
        values, self._met = self._call("do_step", (t, h, tuple([d[n] for n in self._inputs]),
                                                   self.stop_at_events))
        d.update(zip(self._outputs, values, strict=False))

    # -- events, as the worker's FmuComponent meets them (`twmr.master.adaptive`) -------------
    def state_event(self) -> float | None:
        return self._met[0]

    def early_event(self) -> float | None:
        return self._met[1]

    def repeats_steps(self) -> bool:
        return self._met[2]

    def event(self, t: float) -> None:
        if self._met[0] is None:
            return  # nothing met in the last step: nothing held
        self._t = t
        self.__dict__.update(zip(self._outputs, self._call("event", (t,)), strict=False))

    def next_event(self, t: float) -> float | None:
        return self._call("next_event", (t,)) if self._conn is not None else None

    def events_unseen(self) -> str | None:
        return self._desc.events_unseen()

    def controls_its_error(self) -> bool:
        return self._desc.controls_its_error()

    def get_state(self) -> Any:
        """(the worker's `FmuComponent` state, these ports and time): the FMU's own state
        crosses the socket as bytes when it serialises, else as a token the worker holds."""
        if not self.can_get_and_set_state:
            raise self._desc.no_state("save")
        return self._call("get_state"), super().get_state()

    def set_state(self, state: Any) -> None:
        if not self.can_get_and_set_state:
            raise self._desc.no_state("restore")
        worker, values = state
        self._call("set_state", (worker,))
        super().set_state(values)
        self._met = (None, None, True)

    def why_no_state(self) -> str:
        return self._desc.why_no_state()

    def release_state(self, state: Any) -> None:
        if self._conn is not None:
            self._call("release_state", (state[0],))

    def report(self) -> dict[str, Any]:
        return self._report

    def terminate(self) -> None:
        """The FMU's report and terminate (at most `TERMINATE_TIMEOUT` s), then the worker ends;
        never raises."""
        if self._proc is None:
            return
        grace = min(self._timeout, TERMINATE_TIMEOUT)
        try:
            if self._pending and self._conn is not None and \
                    receive(self._conn, self._poll, grace) is not None:
                self._pending = False  # the answer to the call cut short, read
            if not self._pending:
                self._report = self._call("terminate", (), grace)
        except BaseException:  # noqa: BLE001 - terminating after a failure must not mask it
            pass
        finally:
            self._ended = "it was terminated"
            self._end_worker(TERMINATE_TIMEOUT)
