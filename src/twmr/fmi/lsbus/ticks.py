"""`TickedData`: what a bus terminal's Tx_Data held over one communication step, tick by tick.

An FMU's Tx clock may tick more than once inside a step (a countdown clock, an early return);
its Tx_Data port then carries the operations of every tick back to back (`twmr.fmi.clocks`).
`TickedData` is those bytes, and when each tick's operations start and were written, so a bus
that reads the port at the communication point (the `can_bus` block) hands each frame to the
bus at the time the FMU sent it. It is `bytes` everywhere else.
"""
from __future__ import annotations


class TickedData(bytes):
    """Bytes of one or more ticks; `ticks` holds (time [s], offset of the tick's first byte)."""

    ticks: tuple[tuple[float, int], ...]

    def __new__(cls, data: bytes, ticks: tuple[tuple[float, int], ...]) -> TickedData:
        made = super().__new__(cls, data)
        made.ticks = ticks
        return made

    def __reduce__(self) -> tuple[type[TickedData], tuple[bytes, tuple[tuple[float, int], ...]]]:
        return (TickedData, (bytes(self), self.ticks))

    def then(self, t: float, data: bytes) -> TickedData:
        """These bytes followed by those of a tick at t [s]."""
        return TickedData(bytes(self) + data, (*self.ticks, (t, len(self))))

    def parts(self) -> list[tuple[float, bytes]]:
        """(time [s], bytes) of each tick."""
        ends = [at for _, at in self.ticks[1:]] + [len(self)]
        return [(t, bytes(self[at:end])) for (t, at), end in zip(self.ticks, ends, strict=True)]


def tick_parts(data: bytes, t: float) -> list[tuple[float, bytes]]:
    """(time [s], bytes) of each tick in `data` read at the communication point t [s]: those of
    a `TickedData`, else all of it at t."""
    return data.parts() if isinstance(data, TickedData) else [(t, bytes(data))]
