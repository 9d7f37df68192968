"""The bus's faults (`twmr.hw.cansim.FrameFault`, the `can_bus` block's `fault*` parameters):
which frames a fault takes (identifiers, window, count, probability with a seed); a drop: no
receiver gets a lost frame while its sender is confirmed; a duplicate: received twice; a delay:
received that much later, in time order with the rest; a corruption: received with the one bit
flipped; a CRC error: received by no one, an error to its sender, sent again; and the block's
refusals."""
from __future__ import annotations

import math

import can
import pytest

from twmr.hw.canbus_block import CanBus, frame_fault
from twmr.hw.cansim import BusEvent, CanBusModel, FrameFault

pytestmark = pytest.mark.timeout(60)


def run(fault: FrameFault | None, frames: int = 200, ids: tuple[int, ...] = (0x0E, 0x2E),
        period: float = 1e-3) -> list[BusEvent]:
    """`frames` frames of each identifier in `ids` sent by 'host' every `period` [s] to 'drive'."""
    model = CanBusModel(bitrate=1e6, fault=fault)
    model.join("host")
    model.join("drive")
    events: list[BusEvent] = []
    for k in range(frames):
        for ident in ids:
            assert model.submit("host", can.Message(arbitration_id=ident, data=bytes(8),
                                                    is_extended_id=False), k * period) == ""
        events += model.advance((k + 1) * period)
    return events


def kinds(events: list[BusEvent], ident: int) -> list[str]:
    return [e.kind for e in events if e.frame.arbitration_id == ident]


def test_frames_of_the_named_id_in_the_window_are_lost_and_only_those() -> None:
    events = run(FrameFault(frozenset({0x0E}), start=0.05, stop=0.1))
    lost = [e for e in events if e.kind == "dropped"]
    # frames 50..99 of 0x0E end on the wire in [0.05, 0.1): 0x0E wins arbitration at k ms and
    # ends ~0.13 ms later
    assert len(lost) == 50 and {e.frame.arbitration_id for e in lost} == {0x0E}
    assert all(0.05 <= e.time < 0.1 for e in lost)
    # no receiver hears a lost frame; its sender is confirmed as for any frame
    assert kinds(events, 0x0E).count("transmit") == 150
    assert kinds(events, 0x0E).count("confirm") == 200
    assert kinds(events, 0x2E) == ["transmit", "confirm"] * 200
    # a lost frame was on the wire all the same: the others' times are those of a bus without
    # the fault
    assert [e.time for e in events if e.frame.arbitration_id == 0x2E] == \
        [e.time for e in run(None) if e.frame.arbitration_id == 0x2E]


def test_count_limits_the_frames_lost() -> None:
    lost = [e for e in run(FrameFault(count=7)) if e.kind == "dropped"]
    assert len(lost) == 7 and [e.frame.arbitration_id for e in lost] == [0x0E, 0x2E] * 3 + [0x0E]


def test_a_probability_draws_from_its_seed() -> None:
    def lost(seed: int) -> list[float]:
        return [e.time for e in run(FrameFault(probability=0.3, seed=seed), frames=1000)
                if e.kind == "dropped"]

    first, again, other = lost(1), lost(1), lost(2)
    assert first == again and first != other
    # 2000 frames each lost with p = 0.3: 600 expected, sd sqrt(2000 * 0.3 * 0.7) = 20.5
    assert abs(len(first) - 600) < 5 * 20.5 and abs(len(other) - 600) < 5 * 20.5


def test_no_fault_before_the_run_begins_on_the_wall_clock() -> None:
    model = CanBusModel(bitrate=1e6, fault=FrameFault(), run_offset=math.nan)
    model.join("a")
    model.join("b")
    model.submit("a", can.Message(arbitration_id=1, is_extended_id=False), 0.0)
    assert [e.kind for e in model.advance(1.0)] == ["transmit", "confirm"]


@pytest.mark.parametrize("ids, says", [("0x0E, banana", "'banana' is no CAN identifier"),
                                       ("0x20000000", "outside 0 .. 0x1FFFFFFF")])
def test_the_block_refuses_bad_identifiers(ids: str, says: str) -> None:
    block = CanBus("can0", fault_ids=ids)
    problems = block.check(frozenset({"fault_ids"}))
    assert [p[0] for p in problems] == ["fault_ids"] and says in problems[0][1]


def test_the_block_reads_its_fault() -> None:
    assert frame_fault(CanBus("can0")) is None
    fault = frame_fault(CanBus("can0", fault_ids="0x0E; 46", fault_start=2.0, fault_stop=3.0,
                              fault_probability=0.5, fault_seed=9, fault_count=4))
    assert fault == FrameFault(frozenset({0x0E, 46}), 2.0, 3.0, 0.5, 9, 4)
    assert frame_fault(CanBus("can0", fault_ids="all")) == FrameFault()
    problems = CanBus("can0", fault_ids="all", fault_start=3.0, fault_stop=2.0).check(frozenset())
    assert [p[0] for p in problems] == ["fault_stop"]


def test_a_duplicated_frame_is_received_twice_and_confirmed_once() -> None:
    events = run(FrameFault(frozenset({0x0E}), start=0.05, stop=0.06, kind="duplicate"))
    assert kinds(events, 0x0E).count("transmit") == 210  # frames 50..59 twice
    assert kinds(events, 0x0E).count("confirm") == 200
    assert len([e for e in events if e.kind == "faulted"]) == 10


def test_a_delayed_frame_arrives_that_much_later_in_time_order() -> None:
    plain = [e for e in run(None) if e.kind == "transmit" and e.frame.arbitration_id == 0x0E]
    events = run(FrameFault(frozenset({0x0E}), start=0.05, stop=0.06, kind="delay",
                            delay=2.5e-3))
    got = [e for e in events if e.kind == "transmit" and e.frame.arbitration_id == 0x0E]
    assert len(got) == 200
    late = sorted(e.time for e in got if e.time not in {p.time for p in plain})
    assert late == pytest.approx(sorted(p.time + 2.5e-3 for p in plain
                                        if 0.05 <= p.time < 0.06), abs=1e-12)
    times = [e.time for e in events]
    assert times == sorted(times)  # every advance hands its events in time order
    # the sender is confirmed when the frame ended on the wire, not when it was received
    confirms = [e.time for e in events if e.kind == "confirm" and e.frame.arbitration_id == 0x0E]
    assert confirms == [p.time for p in plain]


def test_a_corrupted_frame_arrives_with_its_bit_flipped() -> None:
    events = run(FrameFault(frozenset({0x2E}), count=3, kind="corrupt", bit=10))
    got = [bytes(e.frame.data) for e in events if e.kind == "transmit" and
           e.frame.arbitration_id == 0x2E]
    assert got[:3] == [bytes([0, 0b100, 0, 0, 0, 0, 0, 0])] * 3 and set(got[3:]) == {bytes(8)}
    drawn = run(FrameFault(frozenset({0x2E}), count=50, kind="corrupt", seed=4))
    flips = [bytes(e.frame.data) for e in drawn if e.kind == "transmit" and
             e.frame.arbitration_id == 0x2E][:50]
    assert all(sum(bin(b).count("1") for b in f) == 1 for f in flips)  # one bit each
    assert len(set(flips)) > 20  # drawn, not one bit every time


def test_a_crc_error_reaches_no_one_and_the_sender_sends_it_again() -> None:
    events = run(FrameFault(frozenset({0x0E}), count=2, kind="crc_error"), frames=5)
    assert kinds(events, 0x0E) == ["faulted", "bus_error", "faulted", "bus_error"] + \
        ["transmit", "confirm"] * 5
    errors = [e for e in events if e.kind == "bus_error"]
    assert all("CRC error" in e.detail for e in errors)
    # the retransmissions came first: frame 0 was on the wire three times before 0x2E's first
    first_2e = next(e.time for e in events if e.frame.arbitration_id == 0x2E)
    assert sum(e.time < first_2e for e in events if e.frame.arbitration_id == 0x0E) >= 5


def test_the_block_refuses_an_unknown_fault() -> None:
    problems = CanBus("can0", fault="explode", fault_ids="all").check(frozenset())
    assert [p[0] for p in problems] == ["fault"] and "drop, duplicate" in problems[0][2]
    assert frame_fault(CanBus("can0", fault="delay", fault_ids="0x10", fault_delay=0.002)) == \
        FrameFault(frozenset({0x10}), kind="delay", delay=0.002)


def _two_senders(fault: FrameFault, frames: int = 100, period: float = 1e-3) -> list[BusEvent]:
    """'host' sends 0x0E and 'drive' sends 0x1E every `period` [s]."""
    model = CanBusModel(bitrate=1e6, fault=fault)
    for name in ("host", "drive"):
        model.join(name)
    events: list[BusEvent] = []
    for k in range(frames):
        for sender, ident in (("host", 0x0E), ("drive", 0x1E)):
            model.submit(sender, can.Message(arbitration_id=ident, data=bytes(8),
                                             is_extended_id=False), k * period)
        events += model.advance((k + 1) * period)
    return events


def test_a_fault_on_one_node_takes_only_its_frames() -> None:
    events = _two_senders(FrameFault(kind="drop", senders=frozenset({"drive"})))
    lost = [e for e in events if e.kind == "dropped"]
    assert len(lost) == 100 and {(e.sender, e.frame.arbitration_id) for e in lost} == {
        ("drive", 0x1E)}
    assert kinds(events, 0x0E) == ["transmit", "confirm"] * 100


def test_an_error_frame_is_seen_by_every_node_and_the_frame_sent_again() -> None:
    events = _two_senders(FrameFault(frozenset({0x0E}), start=0.02, stop=0.03,
                                     kind="error_frame"))
    errors = [e for e in events if e.kind == "bus_error"]
    # each destroyed 0x0E: an error to both nodes; sent again at once, destroyed again while
    # the window lasts (0x0E wins every arbitration), then through
    assert errors and {e.sender for e in errors} == {"host", "drive"}
    assert all(0.02 <= e.time < 0.03 for e in errors)
    assert len([e for e in errors if e.sender == "host"]) == len(
        [e for e in errors if e.sender == "drive"])
    assert kinds(events, 0x0E).count("transmit") == 100  # every frame got through in the end
    assert all("error frame" in e.detail for e in errors)


def test_a_node_bus_off_sends_nothing_for_the_window_and_is_told() -> None:
    events = _two_senders(FrameFault(start=0.02, stop=0.05, kind="bus_off",
                                     senders=frozenset({"host"})))
    refused = [e for e in events if e.kind == "bus_error"]
    assert len(refused) == 30 and {e.sender for e in refused} == {"host"}
    assert all("bus-off" in e.detail and 0.02 <= e.time < 0.05 for e in refused)
    sent = [e for e in events if e.kind == "transmit" and e.sender == "host"]
    assert len(sent) == 70 and not any(0.02 <= e.time < 0.05 for e in sent)
    assert kinds(events, 0x1E).count("transmit") == 100  # the other node unharmed


def test_a_babbling_node_floods_the_bus_and_the_others_wait() -> None:
    from twmr.hw.cansim import BABBLER, frame_timing

    events = _two_senders(FrameFault(frozenset({0x001}), start=0.02, stop=0.03,
                                     kind="babble"))
    babble = [e for e in events if e.sender == BABBLER]
    assert {e.kind for e in babble} == {"transmit"} and \
        {e.frame.arbitration_id for e in babble} == {0x001}
    slot = frame_timing(babble[0].frame, 1e6).to_free
    assert abs(len(babble) - 0.01 / slot) <= 2  # back to back for 10 ms
    host = [e.time for e in events if e.kind == "transmit" and e.sender == "host"]
    assert not any(0.02 + slot < t < 0.03 for t in host)  # nothing of the others gets through
    assert len(host) == 100  # they wait, then go
