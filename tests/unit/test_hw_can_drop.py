"""The bus's drop fault (`twmr.hw.cansim.FrameDrop`, the `can_bus` block's `drop_*`
parameters): which frames it takes (identifiers, window, count, probability with a seed), that
no receiver gets a lost frame while its sender is confirmed, and the block's refusals."""
from __future__ import annotations

import math

import can
import pytest

from twmr.hw.canbus_block import CanBus, drop_fault
from twmr.hw.cansim import BusEvent, CanBusModel, FrameDrop

pytestmark = pytest.mark.timeout(60)


def run(fault: FrameDrop | None, frames: int = 200, ids: tuple[int, ...] = (0x0E, 0x2E),
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
    events = run(FrameDrop(frozenset({0x0E}), start=0.05, stop=0.1))
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
    lost = [e for e in run(FrameDrop(count=7)) if e.kind == "dropped"]
    assert len(lost) == 7 and [e.frame.arbitration_id for e in lost] == [0x0E, 0x2E] * 3 + [0x0E]


def test_a_probability_draws_from_its_seed() -> None:
    def lost(seed: int) -> list[float]:
        return [e.time for e in run(FrameDrop(probability=0.3, seed=seed), frames=1000)
                if e.kind == "dropped"]

    first, again, other = lost(1), lost(1), lost(2)
    assert first == again and first != other
    # 2000 frames each lost with p = 0.3: 600 expected, sd sqrt(2000 * 0.3 * 0.7) = 20.5
    assert abs(len(first) - 600) < 5 * 20.5 and abs(len(other) - 600) < 5 * 20.5


def test_no_fault_before_the_run_begins_on_the_wall_clock() -> None:
    model = CanBusModel(bitrate=1e6, fault=FrameDrop(), run_offset=math.nan)
    model.join("a")
    model.join("b")
    model.submit("a", can.Message(arbitration_id=1, is_extended_id=False), 0.0)
    assert [e.kind for e in model.advance(1.0)] == ["transmit", "confirm"]


@pytest.mark.parametrize("ids, says", [("0x0E, banana", "'banana' is no CAN identifier"),
                                       ("0x20000000", "outside 0 .. 0x1FFFFFFF")])
def test_the_block_refuses_bad_identifiers(ids: str, says: str) -> None:
    block = CanBus("can0", drop_ids=ids)
    problems = block.check(frozenset({"drop_ids"}))
    assert [p[0] for p in problems] == ["drop_ids"] and says in problems[0][1]


def test_the_block_reads_its_fault() -> None:
    assert drop_fault(CanBus("can0")) is None
    fault = drop_fault(CanBus("can0", drop_ids="0x0E; 46", drop_start=2.0, drop_stop=3.0,
                              drop_probability=0.5, drop_seed=9, drop_count=4))
    assert fault == FrameDrop(frozenset({0x0E, 46}), 2.0, 3.0, 0.5, 9, 4)
    assert drop_fault(CanBus("can0", drop_ids="all")) == FrameDrop()
    problems = CanBus("can0", drop_ids="all", drop_start=3.0, drop_stop=2.0).check(frozenset())
    assert [p[0] for p in problems] == ["drop_stop"]
