"""Guards for FMUs run in this process (without ``isolate: true``), whose native code Python
cannot interrupt.

- **A call that does not return.** Python runs its signal handlers only between bytecodes, so
  Ctrl-C, SIGTERM or SIGHUP during an FMU call that never returns would change nothing. While an
  FMU is set up, a watchdog thread learns of each such signal through `signal.set_wakeup_fd`; if
  the main thread is still inside the same FMU call `GRACE` s later, or a second signal comes
  while it is, it ends the process with the status a stopped run has (130 for Ctrl-C, 128 +
  the signal otherwise), saying which FMU and call did not return. Components are not terminated
  then (their code would run beside the FMU's) and the rows recorded up to the last chunk stay in
  the run's ``<out>.partial-<pid>`` folder, which `read_result` reads.
- **An FMU that calls exit().** C's exit() ends the process without Python's clean-up, with the
  FMU's status (often 0). A handler registered with the C library (glibc's ``__cxa_atexit``;
  elsewhere there is none) reports it in one paragraph and ends the process with status 1 instead;
  it is unregistered at Python's normal exit, before the C library would run it.

Neither can save the run as a stopped run is saved: ``isolate: true`` can (a worker process of the
FMU's own is killed or reaped and the run ends with an `FmuError`).
"""
from __future__ import annotations

import atexit
import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from types import FrameType
from typing import Any

#: how long the main thread may stay inside one FMU call after a stop signal [s]
GRACE = 5.0
#: set False by the isolation worker, whose parent reports what its FMU does
enabled = True
_STOP = {int(getattr(signal, n)): n for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)}

_lock = threading.Lock()
_active = 0
_watchdog: _Watchdog | None = None
_exit_hook: list[Any] = []  # [callback, key, libc] once registered


def isolation_advice(components: dict[str, Any]) -> list[str]:
    """One warning per FMU of `components` (instance -> component) run in this process: what
    an unattended run (a sweep, a batch) risks with it, and the fix."""
    from twmr.fmi.fmu import FmuComponent

    return [f"component '{name}' runs FMU '{comp.path.name}' in this process: a hang inside it "
            f"stops only with the process, and an exit() or a crash inside it ends the whole "
            f"run (in a sweep, the worker with every run it holds). Fix: for unattended runs "
            f"give it isolate: true and a timeout: under its parameters."
            for name, comp in components.items() if isinstance(comp, FmuComponent)]


def enter() -> None:
    """An in-process FMU is being set up (from any thread): guard it until `leave()`."""
    global _active, _watchdog
    if not enabled:
        return
    with _lock:
        _active += 1
        if not _exit_hook:
            _register_exit_hook()
        if _watchdog is None and threading.current_thread() is threading.main_thread():
            _watchdog = _Watchdog.start()


def leave() -> None:
    """The FMU of a matching `enter()` was terminated."""
    global _active, _watchdog
    if not enabled:
        return
    with _lock:
        _active = max(0, _active - 1)
        if _active == 0 and _watchdog is not None and \
                threading.current_thread() is threading.main_thread():
            _watchdog.stop()
            _watchdog = None


# -- which FMU call a thread is in ------------------------------------------------------------
def _fmu_frame(frame: FrameType | None) -> FrameType | None:
    """The innermost frame of an `FmuComponent` method on the stack ending at `frame`."""
    from twmr.fmi.fmu import FmuComponent

    while frame is not None:
        if isinstance(frame.f_locals.get("self"), FmuComponent):
            return frame
        frame = frame.f_back
    return None


def _compiled_frame(frame: FrameType | None) -> FrameType | None:
    """The innermost frame on the stack ending at `frame` of a compiled step loop that calls
    FMUs through their C functions (its `self` lists them in `fmu_components`)."""
    while frame is not None:
        if getattr(frame.f_locals.get("self"), "fmu_components", None):
            return frame
        frame = frame.f_back
    return None


def _describe(frame: FrameType) -> tuple[str, str, Any]:
    """("component 'dut' at t = 0.29 s: FMU 'x.fmu'", the FMI call, the component) for the
    frame of an FmuComponent method."""
    comp = frame.f_locals["self"]
    if not hasattr(comp, "path"):  # the compiled loop calling FMUs: which one, it cannot tell
        fmus = list(comp.fmu_components)
        named = ", ".join(f"'{c.name}' ({c.path.name})" for c in fmus[:4])
        return (f"the compiled step loop, calling FMU{'s' if len(fmus) > 1 else ''} {named},",
                "an FMU call", fmus[0])
    call = {"do_step": "doStep", "evaluate": "getting or setting values", "setup":
            "instantiation", "initialize": "initialization", "terminate": "terminate"}.get(
        frame.f_code.co_name, frame.f_code.co_name)
    t = getattr(comp, "_t", None)
    at = f" at t = {t:.9g} s" if isinstance(t, float) else ""
    return f"component '{comp.name}'{at}: FMU '{comp.path.name}'", call, comp


def _where_rows(comp: Any) -> str:
    folder = getattr(comp, "run_folder", None)
    return f"the rows recorded so far are in {folder}/" if folder else \
        "the rows recorded so far are lost (the run kept them in memory)"


def _fix() -> str:
    return ("Fix: run this FMU with `isolate: true` under its parameters (with `timeout:`), so "
            "that a hung or exiting FMU ends only its own process and the run is saved.")


def _die(text: str, status: int) -> None:
    with contextlib.suppress(OSError):
        os.write(2, (text.rstrip() + "\n").encode("utf-8", "replace"))
    os._exit(status)


# -- exit() inside an FMU ------------------------------------------------------------------------
def _on_c_exit(_arg: Any) -> None:
    if not _exit_hook or _active == 0:  # unregistering, or no FMU is set up: not an FMU's exit
        return
    frame = _fmu_frame(sys._getframe())
    if frame is None:
        who, call, comp = "an FMU", "a call", None
    else:
        who, call, comp = _describe(frame)
    rows = _where_rows(comp) if comp is not None else "the rows recorded so far may be lost"
    _die(f"error: {who} ended the process (it called exit()) during {call}; the components "
         f"were not terminated and {rows}. {_fix()}", 1)


def _register_exit_hook() -> None:
    try:
        libc = ctypes.CDLL(None)
        register, finalize = libc.__cxa_atexit, libc.__cxa_finalize
    except (OSError, AttributeError):  # not glibc: nothing to register with
        _exit_hook.append(None)
        return
    kind = ctypes.CFUNCTYPE(None, ctypes.c_void_p)
    register.argtypes = [kind, ctypes.c_void_p, ctypes.c_void_p]
    finalize.argtypes = [ctypes.c_void_p]
    callback, key = kind(_on_c_exit), ctypes.create_string_buffer(1)
    if register(callback, None, ctypes.addressof(key)) != 0:
        _exit_hook.append(None)
        return
    _exit_hook.extend([callback, key, finalize])
    atexit.register(_unregister_exit_hook)


def _unregister_exit_hook() -> None:
    """At Python's exit: the C library runs the handler now (it does nothing) and forgets it."""
    if len(_exit_hook) == 3:
        callback, key, finalize = _exit_hook
        _exit_hook.clear()
        finalize(ctypes.addressof(key))
        _exit_hook.append(callback)  # kept alive: the C library held a pointer to it


# -- stop signals during a call that does not return --------------------------------------------
class _Watchdog:
    """The thread that ends the process when a stop signal cannot reach the main thread."""

    def __init__(self, read: int, write: int, previous: int):
        self.read, self.write, self.previous = read, write, previous
        self.main = threading.main_thread().ident
        self.thread = threading.Thread(target=self._run, name="twmr-fmu-watchdog", daemon=True)

    @classmethod
    def start(cls) -> _Watchdog | None:
        """Take the wakeup fd (main thread only); None if another user holds it."""
        read, write = os.pipe()
        os.set_blocking(write, False)
        try:
            previous = signal.set_wakeup_fd(write, warn_on_full_buffer=False)
        except ValueError:
            previous = -2
        if previous != -1:
            if previous >= 0:
                signal.set_wakeup_fd(previous)
            os.close(read)
            os.close(write)
            return None
        watch = cls(read, write, previous)
        watch.thread.start()
        return watch

    def stop(self) -> None:
        with contextlib.suppress(ValueError):
            signal.set_wakeup_fd(-1)
        os.close(self.write)  # the thread reads end of file and ends
        self.thread.join(1.0)

    def _run(self) -> None:
        try:
            while True:
                data = os.read(self.read, 64)
                if not data:
                    return
                for signum in data:
                    if signum in _STOP:
                        self._watch(signum)
        finally:
            os.close(self.read)

    def _innermost(self) -> FrameType | None:
        return sys._current_frames().get(self.main)  # type: ignore[arg-type]

    def _watch(self, signum: int) -> None:
        """After a stop signal: end the process if the main thread stays inside one FMU call
        for `GRACE` s, or at once on a further stop signal while it does."""
        first = self._innermost()
        if first is None or (_fmu_frame(first) or _compiled_frame(first)) is None:
            return
        where = (first, first.f_lasti)
        end = time.monotonic() + GRACE
        while time.monotonic() < end:
            more = _readable(self.read, 0.05)
            if more is None:
                return
            now = self._innermost()
            if now is None or (now, now.f_lasti) != where:
                return  # the main thread moved on: its handler runs
            if any(b in _STOP for b in more):
                break
        frame = _fmu_frame(first) or _compiled_frame(first)
        if frame is None:
            return
        who, call, comp = _describe(frame)
        how = "Ctrl-C" if _STOP[signum] == "SIGINT" else _STOP[signum]
        _die(f"interrupted ({how}): {who} did not return from {call}, and an FMU running in "
             f"this process cannot be stopped, so the process ended without terminating the "
             f"components; {_where_rows(comp)}. {_fix()}", 128 + signum)


def _readable(fd: int, timeout: float) -> bytes | None:
    """What arrives on `fd` within `timeout` [s] (b'' if nothing); None at end of file."""
    import select

    ready, _, _ = select.select([fd], [], [], timeout)
    if not ready:
        return b""
    data = os.read(fd, 64)
    return data or None
