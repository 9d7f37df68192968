"""The worker process of an `IsolatedFmu`: ``python -u -m twmr.fmi.worker FD TMP PATH`` runs one
`FmuComponent` and answers its parent's calls on the socket FD, so whatever the FMU does (crash,
exit(), hang) ends this process only. TMP is its temporary folder (also its TMPDIR), removed by
the parent, or here when the parent has gone; PATH, the FMU, is there for `ps` only.

Protocol, one message each way per call (multiprocessing.connection framing): the request is the
pickled ``(method, args)``, the reply ``(0, value)``, ``(1, the CosimError raised)`` or ``(2, text
of any other exception)``. A step is ``("do_step", (t, h, input values))`` answered by ``(0, output
values)``, in the port orders `initialize` was given (the wired inputs, the outputs read).

Both sides wait for the other by polling the socket for up to `SPIN` seconds before they block:
a process that blocks for each step is woken up tens of microseconds late, which would cost more
than the step itself.

The worker ignores Ctrl-C (its parent stops it) and ends as soon as its standard input reaches end
of file, that is when the parent has gone, even in the middle of an FMU call.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import select
import shutil
import signal
import struct
import sys
import threading
import time
from multiprocessing.connection import Connection
from typing import Any

from twmr.core.errors import CosimError
from twmr.core.run import RunContext
from twmr.fmi import guard
from twmr.fmi.fmu import FmuComponent

#: how long a side polls for the other's message before it blocks [s]
SPIN = 2e-4
#: the bytes the first read of a message asks for: a step's request or reply fits many times
CHUNK = 1 << 16
_SIZE = struct.Struct("!i")
_LONG_SIZE = struct.Struct("!Q")
#: set once the worker ends on its own: the lifeline then leaves the final clean-up alone
_ending = threading.Event()


class _Server:
    """The worker's `FmuComponent` and the calls the parent may make on it."""

    def __init__(self) -> None:
        self.fmu: Any = None
        self.values: dict[str, Any] = {}
        self.inputs: tuple[str, ...] = ()
        self.outputs: tuple[str, ...] = ()

    def create(self, name: str, path: str, kwargs: dict[str, Any],
               values: dict[str, Any]) -> None:
        self.fmu = FmuComponent(name, path, **kwargs)
        for key, value in values.items():
            self.fmu.set_parameter(key, value)
        self.values = self.fmu.__dict__

    def prepare(self, folder: Any, step: float, paced: bool, wired: set[str] | None,
                read: set[str] | None, outputs_as_stepped: bool = False,
                steps_retaken: bool = False, fmu_log: bool = False) -> None:
        """The parent's `RunContext`, narrowed to this instance's wired inputs and read outputs."""
        def pairs(ports: set[str] | None) -> frozenset[tuple[str, str]] | None:
            return None if ports is None else frozenset((self.fmu.name, p) for p in ports)

        self.fmu.prepare(RunContext(folder, step, paced, wired=pairs(wired), read=pairs(read),
                                    outputs_as_stepped=outputs_as_stepped,
                                    steps_retaken=steps_retaken, fmu_log=fmu_log))

    def setup(self, start: float, stop: float | None, hold_events: bool = False) -> None:
        self.fmu.hold_events = hold_events
        self.fmu.setup(start, stop)

    def initialize(self, values: dict[str, Any], inputs: tuple[str, ...],
                   outputs: tuple[str, ...]) -> dict[str, Any]:
        """Every output after initialization; later calls return only `outputs`."""
        self.values.update(values)
        self.inputs, self.outputs = inputs, outputs
        self.fmu.initialize()
        return {n: self.values[n] for n in self.fmu.outputs}

    def evaluate(self, t: float, inputs: tuple[Any, ...]) -> list[Any]:
        d = self.values
        d.update(zip(self.inputs, inputs, strict=False))
        self.fmu.evaluate(t)
        return [d[n] for n in self.outputs]

    def do_step(self, t: float, h: float, inputs: tuple[Any, ...],
                stop_at_events: float | None = None
                ) -> tuple[list[Any], tuple[float | None, float | None, bool]]:
        """The outputs after the step, and what it met: (its first state event, its early
        event, whether it repeats from a save)."""
        d = self.values
        d.update(zip(self.inputs, inputs, strict=False))
        fmu = self.fmu
        fmu.stop_at_events = stop_at_events
        fmu.do_step(t, h)
        return ([d[n] for n in self.outputs],
                (fmu.state_event(), fmu.early_event(), fmu.repeats_steps()))

    def event(self, t: float) -> list[Any]:
        """A state event held at the end of the last step handled; the outputs after it."""
        self.fmu.event(t)
        return [self.values[n] for n in self.outputs]

    def next_event(self, t: float) -> float | None:
        return self.fmu.next_event(t)

    def get_state(self) -> Any:
        """The FMU's state as plain values (bytes, or a token for a state held by the FMU)."""
        return self.fmu.get_state()

    def set_state(self, state: Any) -> None:
        self.fmu.set_state(state)

    def release_state(self, state: Any) -> None:
        self.fmu.release_state(state)

    def terminate(self) -> dict[str, Any]:
        """The FMU's `report()`, taken before it is terminated."""
        figures = self.fmu.report()
        self.fmu.terminate()
        return figures


def wait(poller: select.poll, timeout: float | None) -> bool:
    """Whether the socket registered with `poller` became readable (a message, or closed) within
    `timeout` [s] (None or beyond `poll`'s range: no limit); polls for `SPIN` s first, then
    blocks."""
    end = time.perf_counter() + SPIN
    while not poller.poll(0):
        os.sched_yield()  # the other side may be waiting for this CPU
        if time.perf_counter() > end:
            return bool(poller.poll(_milliseconds(timeout)))
    return True


def _milliseconds(timeout: float | None) -> int | None:
    return None if timeout is None or not timeout * 1e3 < 2**31 - 1 else int(timeout * 1e3)


def receive(conn: Connection, poller: select.poll, timeout: float | None) -> bytes | None:
    """One whole message on `conn` (multiprocessing.connection framing: a 4-byte big-endian
    length, or -1 and an 8-byte one), or None if it is not all there within `timeout` [s] (None:
    no limit). EOFError if the other side closed the socket, ValueError for a bad frame or for
    bytes beyond the message (one call has one answer). A message already all there is read in
    one `os.read`."""
    deadline = None if _milliseconds(timeout) is None else time.monotonic() + float(timeout or 0)
    if not wait(poller, timeout):
        return None
    fd = conn.fileno()
    data = os.read(fd, CHUNK)
    if not data:
        raise EOFError
    if len(data) > 4 and _SIZE.unpack_from(data)[0] == len(data) - 4:
        return data[4:]
    return _rest(fd, poller, bytearray(data), deadline)


def _rest(fd: int, poller: select.poll, data: bytearray, deadline: float | None) -> bytes | None:
    """The message begun by `data`, read to its end by `deadline` (`time.monotonic`), else None."""
    def fill(n: int) -> bool:
        while len(data) < n:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not poller.poll(_milliseconds(left)):
                return False
            chunk = os.read(fd, n - len(data))
            if not chunk:
                raise EOFError
            data.extend(chunk)
        return True

    if not fill(4):
        return None
    (size,) = _SIZE.unpack_from(data)
    start = 4
    if size == -1:
        if not fill(12):
            return None
        (size,), start = _LONG_SIZE.unpack_from(data, 4), 12
    elif size < 0:
        raise ValueError(f"a message length of {size}")
    if len(data) > start + size:
        raise ValueError(f"{len(data) - start - size} bytes beyond a message of {size}")
    return bytes(data[start:]) if fill(start + size) else None


def send(conn: Connection, data: bytes) -> None:
    """`data` as one message on `conn`, in the framing `receive` reads, in one `os.write` when
    the socket takes it whole. OSError if the other side has gone."""
    size = len(data)
    header = _SIZE.pack(size) if size <= 0x7FFFFFFF else _SIZE.pack(-1) + _LONG_SIZE.pack(size)
    view = memoryview(header + data)
    fd = conn.fileno()
    while view:
        view = view[os.write(fd, view):]


def _exit_with_parent(tmp: str) -> None:
    """Block on standard input, which only the parent holds open; at its EOF remove `tmp` and end
    the process."""
    while sys.stdin.buffer.read(4096):
        pass
    if not _ending.is_set():
        shutil.rmtree(tmp, ignore_errors=True)
        with contextlib.suppress(OSError):
            os.killpg(0, signal.SIGKILL)  # this process and any the FMU started
        os._exit(1)


def serve(conn: Connection) -> None:
    """Answer calls on `conn` until `terminate` or the parent closes it."""
    server = _Server()
    poller = select.poll()
    poller.register(conn.fileno(), select.POLLIN)
    while True:
        try:
            request = receive(conn, poller, None)
        except (EOFError, ValueError, OSError):
            return
        assert request is not None  # no time limit
        call, args = pickle.loads(request)
        try:
            reply: tuple[int, Any] = (0, getattr(server, call)(*args))
        except CosimError as exc:
            reply = (1, exc)
        except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent
            reply = (2, f"{type(exc).__name__}: {exc}")
        try:
            data = pickle.dumps(reply, pickle.HIGHEST_PROTOCOL)
        except Exception:  # noqa: BLE001 - an error whose arguments do not pickle
            data = pickle.dumps((2, f"{type(reply[1]).__name__}: {reply[1]}"))
        try:
            send(conn, data)
        except OSError:  # the parent has gone
            return
        if call == "terminate":
            return


def _log_to_stderr() -> None:
    """The FMU's messages to stderr, as the parent's `twmr.fmu` logger would show them (the
    FmuLog chooses each message's level: INFO for all of them with `Options.fmu_log`)."""
    import logging

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger = logging.getLogger("twmr.fmu")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False


def main(argv: list[str] | None = None) -> None:
    """Serve one FMU; `argv` is FD TMP PATH (see the module's docstring)."""
    args = sys.argv[1:] if argv is None else argv
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    guard.enabled = False  # the parent reports what the FMU does to this process
    _log_to_stderr()
    threading.Thread(target=_exit_with_parent, args=(args[1],), name="twmr-lifeline",
                     daemon=True).start()
    serve(Connection(int(args[0])))
    _ending.set()
    shutil.rmtree(args[1], ignore_errors=True)
    sys.stdout.flush()
    sys.stderr.flush()
    ctypes.CDLL(None).fflush(None)  # the FMU's own C output
    os._exit(0)  # no interpreter shutdown: an FMU left loaded may crash it


if __name__ == "__main__":
    main()
