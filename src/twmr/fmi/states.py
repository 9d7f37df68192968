"""`FmuStates`: the FMU states one instance saves (fmi2GetFMUstate / fmi3GetFMUState), freed
when they are no longer needed.

An FMU that can serialise its state (`canSerializeFMUstate`) gives bytes: one FMU-side state is
reused for every save (FMI lets fmiGetFMUstate overwrite a state it returned) and a restore
deserialises into a fresh one, sets it and frees it, so no FMU memory grows with the number of
saves and the bytes cross process boundaries. Otherwise a save gives a token (an int) naming a
state held here; at most `KEEP` are held, the oldest freed first, and `release` frees one at once.
"""
from __future__ import annotations

import contextlib
import itertools
from collections import OrderedDict
from collections.abc import Callable
from ctypes import byref, c_void_p
from typing import Any

#: the most unserialised states held at once per instance (the oldest is freed beyond)
KEEP = 64


class StateGone(LookupError):
    """A token whose state was released, or freed as one of more than `KEEP` held."""


class FmuStates:
    """Saved states of one instantiated fmpy FMU (FMI 2.0 or 3.0); `call(what, fn, *args)`
    runs an FMI call, raising `FmuError` on failure."""

    def __init__(self, fmu: Any, fmi3: bool, serialize: bool, call: Callable[..., Any]):
        self.fmu, self.fmi3, self.serialize, self.call = fmu, fmi3, serialize, call
        self.version = "fmi3" if fmi3 else "fmi2"
        self.state = "FMUState" if fmi3 else "FMUstate"
        self._scratch: c_void_p | None = None
        self._held: OrderedDict[int, c_void_p] = OrderedDict()
        self._tokens = itertools.count(1)

    def _get(self, handle: c_void_p) -> None:
        get = getattr(self.fmu, f"{self.version}Get{self.state}")
        self.call(f"{self.version}Get{self.state}", get, self.fmu.component, byref(handle))

    def _free(self, handle: c_void_p) -> None:
        if handle.value:
            self.call(f"{self.version}Free{self.state}", self.fmu.freeFMUState, handle)

    def save(self) -> bytes | int:
        """The FMU's present state: its serialised bytes, or a token for a state held here."""
        if self.serialize:
            if self._scratch is None:
                self._scratch = c_void_p()
            self._get(self._scratch)
            return bytes(self.call(f"{self.version}Serialize{self.state}",
                                   self.fmu.serializeFMUState, self._scratch))
        handle = c_void_p()
        self._get(handle)
        token = next(self._tokens)
        self._held[token] = handle
        while len(self._held) > KEEP:
            self._free(self._held.popitem(last=False)[1])
        return token

    def restore(self, saved: bytes | int) -> None:
        """Set the FMU to a state `save` returned; raises `StateGone` for a freed token."""
        set_ = f"{self.version}Set{self.state}"
        if isinstance(saved, int):
            handle = self._held.get(saved)
            if handle is None:
                raise StateGone(saved)
            self._held.move_to_end(saved)
            self.call(set_, self.fmu.setFMUState, handle)
            return
        name = "deserializeFMUState" if self.fmi3 else "deSerializeFMUstate"
        handle = self.call(f"{self.version}DeSerialize{self.state}", getattr(self.fmu, name),
                           saved)
        try:
            self.call(set_, self.fmu.setFMUState, handle)
        finally:
            self._free(handle)

    def release(self, saved: bytes | int) -> None:
        """Free the state behind a token now (bytes hold nothing here)."""
        if isinstance(saved, int) and saved in self._held:
            self._free(self._held.pop(saved))

    def close(self) -> None:
        """Free every state held (before the instance is freed); never raises."""
        handles = [*self._held.values(), *([self._scratch] if self._scratch else [])]
        self._held.clear()
        self._scratch = None
        for handle in handles:
            with contextlib.suppress(Exception):  # freeing must not mask the outcome
                self._free(handle)

    def __len__(self) -> int:
        return len(self._held)
