"""The LS-BUS side of the bus block (`twmr.hw.lsbus_node`, `twmr.hw.steppedbus`): operations to
frames and bus events to operations, both arbitration-lost behaviours, the Rx_Data size limit,
and a stepped bus's state restored."""
from __future__ import annotations

import pickle

from twmr.fmi.lsbus import operations as ops
from twmr.fmi.lsbus.ticks import TickedData, tick_parts
from twmr.hw.cansim import BusEvent, CanBusModel, frame_timing
from twmr.hw.lsbus_node import LsBusNode, frame_of, operation_of
from twmr.hw.steppedbus import SteppedBus


def test_transmit_operations_and_frames_map_both_ways() -> None:
    for op in (ops.CanTransmit(0x123, b"\x01\x02"), ops.CanTransmit(0x1ABCDEF, b"", ide=True),
               ops.CanTransmit(0x55, b"", rtr=True, dlc=3),
               ops.CanFdTransmit(0x7, bytes(12), brs=True), ops.CanFdTransmit(0x8, b"", esi=True)):
        frame = frame_of(op)
        assert operation_of(BusEvent("transmit", 1.0, frame, "x"), False) == op
    remote = frame_of(ops.CanTransmit(0x55, b"", rtr=True, dlc=3))
    assert remote.is_remote_frame and remote.dlc == 3 and not remote.data


def test_what_the_sender_is_told() -> None:
    frame = frame_of(ops.CanTransmit(0x42, b"\x01"))
    assert operation_of(BusEvent("confirm", 0.0, frame, "a"), False) == ops.Confirm(0x42)
    assert operation_of(BusEvent("arbitration_lost", 0.0, frame, "a"), False) is None
    assert operation_of(BusEvent("arbitration_lost", 0.0, frame, "a"), True) == \
        ops.ArbitrationLost(0x42)
    ack = BusEvent("bus_error", 0.0, frame, "a", "ACK error: no other participant ...")
    assert operation_of(ack, False) == ops.BusError(0x42, ops.ERROR_ACK, ops.FLAG_PRIMARY, True)
    refused = BusEvent("bus_error", 0.0, frame, "a", "data of 9 bytes is longer than ...")
    assert operation_of(refused, False).error_code == ops.ERROR_FORM
    assert operation_of(BusEvent("unheard", 0.0, frame, "a"), False) is None


def stepped(*names: str) -> tuple[SteppedBus, dict[str, LsBusNode]]:
    bus = SteppedBus("can0", CanBusModel(bitrate=500_000))
    nodes = {n: LsBusNode(n, n, "CanChannel") for n in names}
    for node in nodes.values():
        bus.join(node)
    return bus, nodes


def test_buffer_and_retransmit_or_discard_and_notify() -> None:
    for discard in (False, True):
        bus, nodes = stepped("a", "b")
        if discard:
            nodes["b"].discard = True
            bus.model.discarding.add("b")
        bus.submit("a", frame_of(ops.CanTransmit(0x10, b"\x01")), at=0.1)
        bus.submit("b", frame_of(ops.CanTransmit(0x20, b"\x02")), at=0.1)
        bus.advance(0.2)
        told = ops.decode(nodes["b"].received())
        if discard:
            assert told == [ops.ArbitrationLost(0x20), ops.CanTransmit(0x10, b"\x01")]
            assert bus.counts["transmit"] == 1
        else:
            assert told == [ops.CanTransmit(0x10, b"\x01"), ops.Confirm(0x20)]
            assert bus.counts["transmit"] == 2
        assert bus.counts["arbitration_lost"] == 1


def test_the_rx_data_limit_holds_the_rest_for_the_next_point() -> None:
    bus, nodes = stepped("a", "b")
    nodes["b"].limit = 50  # two CAN Transmit operations of 4 bytes (24 bytes each)
    for k in range(3):
        bus.submit("a", frame_of(ops.CanTransmit(k, b"\x00" * 4)), at=0.0)
    bus.advance(1.0)
    assert [op.id for op in ops.decode(nodes["b"].received())] == [0, 1]
    assert [op.id for op in ops.decode(nodes["b"].received())] == [2]
    assert nodes["b"].received() == b""


def test_a_stepped_bus_is_restored_to_its_snapshot() -> None:
    bus, _ = stepped("a", "b")
    bus.submit("a", frame_of(ops.CanTransmit(0x1, b"\x01")), at=0.0)
    saved = bus.snapshot()
    for _ in range(2):
        bus.advance(1.0)
        assert bus.counts["transmit"] == 1 and len(bus.rows) == 1
        bus.restore(saved)
        assert bus.counts["transmit"] == 0 and bus.next_time() == 0.0
    end = frame_timing(frame_of(ops.CanTransmit(0x1, b"\x01")), 500_000).to_eof
    bus.advance(end - 1e-9)
    assert bus.counts["transmit"] == 0 and bus.next_time() == end


def test_ticked_data_keeps_each_ticks_time() -> None:
    data = TickedData(b"ab", ((0.25, 0),)).then(0.3, b"cde")
    assert data == b"abcde" and tick_parts(data, 0.4) == [(0.25, b"ab"), (0.3, b"cde")]
    assert tick_parts(b"xyz", 0.4) == [(0.4, b"xyz")]
    assert pickle.loads(pickle.dumps(data)).ticks == data.ticks
