"""The flood watch's measure (`CanBusModel.longest_wait`): how long a frame waited for the bus in
the bus's own time. Behind a node that queues identifier 0 faster than the bus carries it, the
host's frame waits on and on (its wait grows while it waits, before it ever gets on); a bench's
own traffic — torques, remote requests and their answers every 2 ms — keeps every wait below a
millisecond. Frames handed over late (a participant stepped in run time behind the wall clock)
count from when they were handed over, not from their due time."""
from __future__ import annotations

import can

from twmr.hw.cansim import CanBusModel


def frame(ident: int, n: int = 8) -> can.Message:
    return can.Message(arbitration_id=ident, data=bytes(n), is_extended_id=False)


def model() -> CanBusModel:
    m = CanBusModel(1_000_000.0, 0.0, False, "exact")
    for name in ("flood", "host", "drives"):
        m.join(name)
    return m


def test_behind_a_flood_the_hosts_frame_waits_as_long_as_the_flood_lasts() -> None:
    m = model()
    for k in range(2000):  # 2000 frames due from t = 0, about 0.23 s of bus time
        m.submit("flood", frame(0x000), k * 1e-5)
    m.submit("host", frame(0x00E), 0.0)
    m.advance(0.15)
    assert m.longest_wait >= 0.1  # still waiting, not yet on the wire
    m.longest_wait = 0.0
    m.advance(1.0)
    assert m.longest_wait >= 0.2  # it went on once the flood was carried


def test_a_benchs_own_traffic_waits_less_than_a_millisecond() -> None:
    m = model()
    for step in range(500):  # 1 s at 2 ms: two torques, two requests, two answers
        t = step * 2e-3
        for node in (0, 1):
            m.submit("host", frame(node << 5 | 0x0E), t)
            m.submit("host", frame(node << 5 | 0x09, 0), t)
            m.submit("drives", frame(node << 5 | 0x09), t + 2e-4)
        m.advance(t + 2e-3)
    assert 0.0 < m.longest_wait < 1e-3


def test_a_frame_handed_over_late_counts_from_its_hand_over() -> None:
    m = model()
    m.submit("host", frame(0x00E), 0.0, queued=0.5)  # due at 0, handed over at 0.5
    m.advance(1.0)
    assert m.longest_wait < 1e-3
