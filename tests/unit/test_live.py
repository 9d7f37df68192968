"""The live view's server (`twmr.observers.live`): loopback by default, a client that never reads
never blocks the run (its rows waiting stay bounded, the oldest dropped), other viewers still get
every row, foreign pages are refused, the page and its vendored plots are served."""
from __future__ import annotations

import base64
import contextlib
import json
import os
import socket
import threading
import urllib.error
import urllib.request
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from twmr.cli import parser
from twmr.observers.base import Outcome, RunStart
from twmr.observers.live import (
    CLIENT_ROWS,
    FRAME_ROWS,
    LiveAddressError,
    LiveView,
    parse_address,
)

RUN = RunStart(("time", "a.pos[1]", "a.pos[2]", "b.u"), ("s", "m", "m", "N"), 1e-3, 10_000)


def _wait_for(condition, tries: int = 400) -> None:
    """Until `condition()` holds (a bounded wait for another thread, no timing assert)."""
    event = threading.Event()
    for _ in range(tries):
        if condition():
            return
        event.wait(0.025)
    raise AssertionError("the condition never held")


def _rows(message: bytes, width: int) -> tuple[float, np.ndarray]:
    values = np.frombuffer(message, dtype="<f8")
    return float(values[0]), values[1:].reshape(-1, width)


@pytest.fixture
def view():
    live = LiveView("0")
    live.started(RUN)
    yield live
    live.close()


def test_binds_loopback_by_default():
    assert parse_address("8765") == ("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:80") == ("0.0.0.0", 80)
    assert parse_address("[::1]:9000") == ("::1", 9000)
    args = parser().parse_args(["run", "s.yaml", "--live", "0"])
    live = LiveView(args.live)
    try:
        url = live.start()
        assert live._server.socket.getsockname()[0] == "127.0.0.1"
        assert url == f"http://127.0.0.1:{live.port}/" and live.port > 0
    finally:
        live.close()
    assert LiveView().host == "127.0.0.1"


def test_bad_addresses_are_refused_with_a_fix():
    for text in ("abc", "127.0.0.1:99999", "host:"):
        with pytest.raises(LiveAddressError, match="Fix:"):
            parse_address(text)
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    try:
        with pytest.raises(LiveAddressError, match=r"cannot listen there.*Fix:"):
            LiveView(f"127.0.0.1:{taken.getsockname()[1]}").start()
    finally:
        taken.close()


def _silent_client(port: int) -> socket.socket:
    """A WebSocket client that completes the handshake and then never reads."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                 f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                 f"Sec-WebSocket-Version: 13\r\n\r\n".encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return sock


def test_a_client_that_never_reads_never_blocks_the_run(view):
    """The silent client's rows waiting stay bounded, the oldest dropped; the healthy reader
    gets every row, in order, in frames numbered without a gap."""
    silent = _silent_client(view.port)
    received: list[bytes | str] = []
    with connect(f"ws://127.0.0.1:{view.port}/ws", max_size=None) as healthy:
        assert json.loads(healthy.recv(timeout=10))["columns"] == list(RUN.columns)
        reader = threading.Thread(target=lambda: received.extend(iter(healthy)), daemon=True)
        reader.start()
        _wait_for(lambda: len(view.clients) == 2)
        port = silent.getsockname()[1]
        reader_side = next(c for c in view.clients if c.connection.remote_address[1] != port)
        chunks = 2_000
        block = np.zeros((FRAME_ROWS, 4))
        for k in range(1, chunks + 1):
            block[:, 0] = k
            # a run no faster than the healthy page reads: its queue never fills
            _wait_for(lambda: reader_side.waiting <= CLIENT_ROWS - FRAME_ROWS)
            view.rows(block, FRAME_ROWS * k)
            assert all(c.waiting <= CLIENT_ROWS for c in view.clients)
        slow = max(view.clients, key=lambda c: c.dropped)
        assert slow.taken + slow.waiting + slow.dropped == chunks * FRAME_ROWS
        assert slow.dropped > chunks * FRAME_ROWS // 2
        view.finished(Outcome(steps_done=2_000_000))  # closes the view: the healthy one ends
        reader.join(timeout=30)
    silent.close()
    assert json.loads(received[-1]) == {"type": "end", "status": "completed", "error": "",
                                        "steps_done": 2_000_000}
    frames = [_rows(m, 4) for m in received if isinstance(m, bytes)]
    assert [s for s, _ in frames] == list(range(1, len(frames) + 1))  # no gap
    got = np.concatenate([rows for _, rows in frames])
    assert np.array_equal(got[:, 0], np.repeat(np.arange(1, chunks + 1), FRAME_ROWS))


def test_rows_waiting_past_the_bound_are_dropped_oldest_first_and_the_gap_is_numbered():
    from twmr.observers.live import _Client

    client = _Client(connection=None)
    for k in range(CLIENT_ROWS // FRAME_ROWS + 3):
        client.push_rows(np.full((FRAME_ROWS, 2), float(k)))
    assert client.waiting == CLIENT_ROWS and client.dropped == 3 * FRAME_ROWS
    sequence, rows = _rows(client.pop(), 2)
    assert sequence == 2 and rows[0, 0] == 3.0 and len(rows) == CLIENT_ROWS  # 1 skipped
    client.push("end")
    client.push_rows(np.ones((2, 2)))
    assert client.pop() == "end" and _rows(client.pop(), 2)[0] == 3


def test_big_chunks_are_thinned_and_late_pages_get_the_history(view):
    block = np.arange(1001 * 4, dtype=float).reshape(1001, 4)
    view.rows(block, 1001)
    with connect(f"ws://127.0.0.1:{view.port}/ws") as late:
        start = json.loads(late.recv(timeout=10))
        assert start["planar"] == [{"port": "a.pos", "x": 1, "y": 2}]
        sequence, rows = _rows(late.recv(timeout=10), 4)
    stride = -(-1001 // FRAME_ROWS)
    assert sequence == -1 and np.array_equal(rows, block[::stride]) and len(rows) <= FRAME_ROWS


def test_foreign_pages_and_hosts_are_refused(view):
    with pytest.raises(InvalidStatus, match="403"):
        connect(f"ws://127.0.0.1:{view.port}/ws",
                additional_headers={"Origin": "http://evil.example"})
    for host in (f"evil.example:{view.port}", f"127.evil.example:{view.port}",
                 f"127.0.0.1.evil.example:{view.port}", f"localhost:{view.port + 1}",
                 "127.0.0.1"):
        request = urllib.request.Request(f"http://127.0.0.1:{view.port}/",
                                         headers={"Host": host})
        with pytest.raises(urllib.error.HTTPError, match="403"):
            urllib.request.urlopen(request, timeout=10)
    for host in (f"localhost:{view.port}", f"127.0.0.2:{view.port}"):
        request = urllib.request.Request(f"http://127.0.0.1:{view.port}/",
                                         headers={"Host": host})
        with urllib.request.urlopen(request, timeout=10) as page:
            assert page.status == 200


def test_the_page_writes_data_as_text_never_as_html():
    html = (resources.files("twmr.observers") / "live_static" / "live.html").read_text()
    assert "innerHTML" not in html and "outerHTML" not in html
    assert "insertAdjacentHTML" not in html and "document.write" not in html


def test_the_page_and_the_vendored_plots_are_served(view):
    with urllib.request.urlopen(f"http://127.0.0.1:{view.port}/", timeout=10) as page:
        assert page.headers["Content-Type"].startswith("text/html")
        html = page.read().decode()
    assert '<script src="uPlot.iife.min.js">' in html and "new WebSocket" in html
    static = resources.files("twmr.observers") / "live_static"
    for name in ("uPlot.iife.min.js", "uPlot.min.css", "uPlot.LICENSE"):
        with urllib.request.urlopen(f"http://127.0.0.1:{view.port}/{name}", timeout=10) as f:
            assert f.read() == (static / name).read_bytes()
    assert "MIT" in (static / "uPlot.LICENSE").read_text()


def test_simulate_live_serves_the_run_and_closes_after(caplog):
    import twmr
    from twmr.observers.base import Observer

    fixture = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"
    seen: dict[str, object] = {}

    class Viewer(Observer):  # a page connecting while the run goes, from its first rows on
        def rows(self, block, steps_done):
            if "start" in seen or not len(block):
                return
            url = next(r.getMessage() for r in caplog.records if r.name == "twmr.live")
            with connect(url.split(": ", 1)[1].replace("http", "ws") + "ws") as page:
                seen["start"] = json.loads(page.recv(timeout=10))
                seen["rows"] = _rows(page.recv(timeout=10), len(block[0]))[1]
            seen["block"] = block.copy()

    caplog.set_level("INFO", logger="twmr.live")
    result = twmr.simulate(str(fixture), live="127.0.0.1:0", observers=[Viewer()])
    assert seen["start"]["columns"] == list(result.columns)
    assert np.array_equal(seen["rows"], seen["block"][::-(-len(seen["block"]) // FRAME_ROWS)])
    assert not [t for t in threading.enumerate() if t.name == "twmr-live"]


def test_the_start_names_elements_from_descriptions_and_marks_discrete_ports_as_steps():
    run = RunStart(("time", "p.pose[1]", "p.pose[2]", "p.pose[3]", "st.counter", "g.y"),
                   ("s", "m", "m", "rad", "", ""), 1e-3, 10,
                   metadata={"ports": {"p.pose": {"description": "(x_M, y_M, theta)",
                                                  "type": "Real"},
                                       "st.counter": {"description": "steps", "type": "Integer"},
                                       "g.y": {"description": "", "type": "Real"}}})
    live = LiveView("0")
    try:
        live.started(run)
        with connect(f"ws://127.0.0.1:{live.port}/ws") as page:
            start = json.loads(page.recv(timeout=10))
    finally:
        live.close()
    assert start["labels"] == ["time", "p.pose x_M", "p.pose y_M", "p.pose theta",
                               "st.counter", "g.y"]
    assert start["stepped"] == [False, False, False, False, True, False]


def test_a_page_that_connects_while_the_view_closes_is_turned_away(view):
    """A page (a reconnecting tab) whose connection opens after close() told the others: it is
    sent the close at once and close() returns (its handler used to wait for data forever, and
    close() for the handler: `twmr run --live` hung after its run, its result never
    promoted)."""
    from websockets.exceptions import ConnectionClosed

    real = view._server.shutdown
    late: list = []
    pages = contextlib.ExitStack()

    def shutdown(*args, **kwargs) -> None:
        page = pages.enter_context(connect(f"ws://127.0.0.1:{view.port}/ws"))
        late.append(page)  # its handshake is done before the shutdown
        _wait_for(lambda: view.clients or getattr(view, "_closing", False))  # its handler ran
        real(*args, **kwargs)

    view._server.shutdown = shutdown
    closer = threading.Thread(target=view.close, daemon=True)
    closer.start()
    closer.join(60)
    assert not closer.is_alive(), "close() waited on the late page"
    with pages, pytest.raises(ConnectionClosed) as closed:
        while True:
            late[0].recv(timeout=10)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1001


def test_a_pages_commands_act_on_the_gate_and_nothing_else_does() -> None:
    from twmr.master.gate import Gate

    gate = Gate()
    live = LiveView("0", gate=gate)
    for text in ("not json", "[1, 2]", '{"type": "reboot"}', '{"type": "step", "steps": -5}',
                 '{"type": "step", "steps": "10"}', '{"type": "step", "steps": 1e12}'):
        live.command(text)
        assert not gate.paused
    live.command('{"type": "pause"}')
    assert gate.paused
    live.command('{"type": "step", "steps": 25}')
    assert gate.paused and gate._limit == 25
    live.command('{"type": "resume"}')
    assert not gate.paused


def test_the_last_page_leaving_a_paused_run_lets_it_go_on() -> None:
    """Nothing waits forever: a page that pauses the run and goes resumes it."""
    from twmr.master.gate import Gate

    gate = Gate()
    live = LiveView("0", gate=gate)
    live.started(RUN)
    try:
        with connect(f"ws://127.0.0.1:{live.port}/ws") as page:
            assert json.loads(page.recv(timeout=10))["control"] is True
            page.send('{"type": "pause"}')
            assert json.loads(page.recv(timeout=10)) == {"type": "control", "paused": True}
        _wait_for(lambda: not gate.paused)
    finally:
        live.close()
