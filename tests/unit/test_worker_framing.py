"""The isolation worker's message framing (`twmr.fmi.worker.send` / `receive`) against Python's own
`multiprocessing.connection`: messages cross in both directions byte for byte (one read for a small
one, a large one in pieces), and a truncated, oversized, negative or over-long frame is refused
(None on time-out, EOFError, ValueError) instead of being taken for a reply."""
from __future__ import annotations

import os
import select
import socket
import struct
import sys
import threading
import time
from collections.abc import Iterator
from multiprocessing.connection import Connection

import pytest

from twmr.fmi.worker import CHUNK, receive, send

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="Unix socket pairs, poll")


@pytest.fixture
def pair() -> Iterator[tuple[Connection, Connection, select.poll]]:
    a, b = socket.socketpair()
    ours, theirs = Connection(a.detach()), Connection(b.detach())
    poller = select.poll()
    poller.register(ours.fileno(), select.POLLIN)
    yield ours, theirs, poller
    for conn in (ours, theirs):
        if not conn.closed:
            conn.close()


@pytest.mark.parametrize("size", [0, 1, 200, CHUNK - 4, CHUNK, 3 * CHUNK + 7])
def test_multiprocessing_messages_are_received_whole(pair, size) -> None:
    ours, theirs, poller = pair
    message = bytes(range(256)) * (size // 256) + bytes(size % 256)
    writer = threading.Thread(target=theirs.send_bytes, args=(message,))
    writer.start()
    assert receive(ours, poller, 10.0) == message
    writer.join()


@pytest.mark.parametrize("size", [0, 5, 3 * CHUNK + 7])
def test_sent_messages_are_read_by_multiprocessing(pair, size) -> None:
    ours, theirs, _ = pair
    message = b"\x80" * size
    writer = threading.Thread(target=send, args=(ours, message))
    writer.start()
    assert theirs.recv_bytes() == message
    writer.join()


def test_a_message_sent_in_pieces_is_joined(pair) -> None:
    ours, theirs, poller = pair
    frame = struct.pack("!i", 6) + b"abcdef"

    def slowly() -> None:
        for piece in (frame[:2], frame[2:7], frame[7:]):
            os.write(theirs.fileno(), piece)
            time.sleep(0.05)

    writer = threading.Thread(target=slowly)
    writer.start()
    assert receive(ours, poller, 10.0) == b"abcdef"
    writer.join()


def test_a_header_without_its_message_times_out(pair) -> None:
    ours, theirs, poller = pair
    os.write(theirs.fileno(), struct.pack("!i", 16) + b"abc")
    assert receive(ours, poller, 0.3) is None


def test_nothing_at_all_times_out(pair) -> None:
    ours, _, poller = pair
    assert receive(ours, poller, 0.05) is None


def test_a_closed_socket_mid_message_is_end_of_file(pair) -> None:
    ours, theirs, poller = pair
    os.write(theirs.fileno(), struct.pack("!i", 16) + b"abc")
    theirs.close()
    with pytest.raises(EOFError):
        receive(ours, poller, 5.0)


def test_a_closed_socket_is_end_of_file(pair) -> None:
    ours, theirs, poller = pair
    theirs.close()
    with pytest.raises(EOFError):
        receive(ours, poller, 5.0)


def test_a_negative_length_is_a_bad_frame(pair) -> None:
    ours, theirs, poller = pair
    os.write(theirs.fileno(), struct.pack("!i", -5) + b"abcde")
    with pytest.raises(ValueError, match="length of -5"):
        receive(ours, poller, 5.0)


def test_bytes_beyond_the_message_are_a_bad_frame(pair) -> None:
    ours, theirs, poller = pair
    os.write(theirs.fileno(), struct.pack("!i", 3) + b"abc" + b"garbage")
    with pytest.raises(ValueError, match="7 bytes beyond a message of 3"):
        receive(ours, poller, 5.0)


def test_the_long_header_form_is_read(pair) -> None:
    ours, theirs, poller = pair
    os.write(theirs.fileno(), struct.pack("!i", -1) + struct.pack("!Q", 4) + b"wxyz")
    assert receive(ours, poller, 5.0) == b"wxyz"
