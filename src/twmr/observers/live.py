"""`LiveView`: live scopes of a run's recorded signals in the browser (`twmr run --live`).

An HTTP + WebSocket server (`websockets`' threaded server) on 127.0.0.1 unless told otherwise
serves one page (`live_static/live.html`: scopes and the XY view plotted with the vendored uPlot,
a 3D view of the vehicles drawn on a canvas, and the scenario's diagram (`twmr.diagram`, served as
`/diagram.svg`, `?closed=robot,...` for subsystems drawn as one block; a click on a port opens
its scope, on a subsystem closes or opens it)) and streams the rows
the run records to every page that connects. The run never waits for a viewer: `rows` decimates
the chunk to at most `FRAME_ROWS` rows and appends it to each client's queue, where the rows
not yet sent gather into one frame (at most `CLIENT_ROWS` rows, the oldest dropped past it);
each client's own thread sends from its queue, so a slow page gets fewer, bigger frames. A page
that joins late gets the run's start and its history (at most `HISTORY_ROWS` rows, thinned by
halves).

Wire format: text messages are JSON (`start`: columns, units, step, n_steps, scenario, ports,
planar, and per column its label (element names from the port's description, as in the plots)
and whether it is drawn as steps (an Integer, Boolean or Enumeration port); `end`: status,
error, steps_done); binary messages are rows: little-endian float64, the frame's sequence number
first (a skipped number: rows were dropped), then rows x columns, row-major."""
from __future__ import annotations

import collections
import contextlib
import ipaddress
import json
import logging
import math
import socket
import threading
from importlib import resources
from pathlib import PurePosixPath
from typing import Any
from urllib.parse import parse_qs, urlsplit

import numpy as np

from twmr.core.errors import CosimError
from twmr.master.gate import Gate
from twmr.observers.base import Observer, Outcome, RunStart
from twmr.plots import (
    STEPWISE_TYPES,
    element_names,
    event_marks,
    group_ports,
    is_planar_position,
)

log = logging.getLogger("twmr.live")

DEFAULT_HOST = "127.0.0.1"
#: most rows one frame carries (a chunk with more is thinned by a stride)
FRAME_ROWS = 500
#: rows waiting for one client; past it the oldest are dropped
CLIENT_ROWS = 50_000
#: rows kept for pages that join late (thinned by halves past it)
HISTORY_ROWS = 20_000
_STATIC = {"/": ("live.html", "text/html; charset=utf-8"),
           "/uPlot.iife.min.js": ("uPlot.iife.min.js", "text/javascript; charset=utf-8"),
           "/uPlot.min.css": ("uPlot.min.css", "text/css; charset=utf-8"),
           "/uPlot.LICENSE": ("uPlot.LICENSE", "text/plain; charset=utf-8")}
_LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
#: diagrams kept drawn (one per set of closed subsystems asked for)
DIAGRAMS_KEPT = 32
#: the most close() waits for the pages to let go [s]
CLOSE_WAIT = 5.0


class LiveAddressError(CosimError):
    """A `--live` address that does not parse or cannot be bound."""


def parse_address(text: str, option: str = "--live") -> tuple[str, int]:
    """'8765' -> ('127.0.0.1', 8765); 'HOST:PORT'; '[::1]:8765'; port 0: a free one. `option`
    names the setting in the error."""
    raw = str(text).strip()
    host, sep, port = raw.rpartition(":")
    if not sep:
        host, port = DEFAULT_HOST, raw
    host = host.strip("[]") or DEFAULT_HOST
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise LiveAddressError(
            f"{option} {text!r}: expected [HOST:]PORT with a port from 0 to 65535. Fix: e.g. "
            f"{option} 8765, {option} 0 (a free port) or {option} 127.0.0.1:8765.")
    return host, int(port)


class _Client:
    """One viewer's queue: the start and end messages, and the rows not yet sent gathered into
    one frame (a page that reads slowly gets bigger frames, not fewer rows); past
    `CLIENT_ROWS` rows waiting the oldest are dropped, and the frame's sequence number skips
    one to say so."""

    def __init__(self, connection: Any) -> None:
        self.connection = connection
        self.queue: collections.deque[str | list[np.ndarray] | None] = collections.deque()
        self.ready = threading.Condition()
        self.waiting = 0  # rows queued
        self.sequence = 0  # of the frames sent
        self.gap = False  # rows dropped since the last frame
        self.dropped = 0  # rows dropped
        self.taken = 0  # rows taken to send (the last frame may still be on its way)

    def push(self, message: str | None) -> None:
        with self.ready:
            self.queue.append(message)
            self.ready.notify()

    def push_rows(self, rows: np.ndarray) -> None:
        with self.ready:
            if self.queue and isinstance(self.queue[-1], list):
                self.queue[-1].append(rows)
            else:
                self.queue.append([rows])
            self.waiting += len(rows)
            while self.waiting > CLIENT_ROWS:
                oldest = next(q for q in self.queue if isinstance(q, list))
                lost = oldest.pop(0)
                self.waiting -= len(lost)
                self.dropped += len(lost)
                self.gap = True
                if not oldest:
                    self.queue.remove(oldest)
            self.ready.notify()

    def pop(self) -> bytes | str | None:
        with self.ready:
            while not self.queue:
                self.ready.wait()
            item = self.queue.popleft()
            if not isinstance(item, list):
                return item
            rows = np.concatenate(item)
            self.waiting -= len(rows)
            self.taken += len(rows)
            self.sequence += 2 if self.gap else 1
            self.gap = False
            return _frame(float(self.sequence), rows)


class LiveView(Observer):
    """Serves the live page on `address` ('[HOST:]PORT', see `parse_address`) from `start()` (or
    the run's start) to `close()`; `keep`: stay up after the run (else `finished` closes)."""

    def __init__(self, address: str = f"{DEFAULT_HOST}:0", keep: bool = False,
                 gate: Gate | None = None):
        self.host, self.port = parse_address(address)
        self.keep = keep
        self.gate = gate  # the page's Pause, Step and Resume act on the run through it
        self.clients: list[_Client] = []
        self._lock = threading.Lock()
        self._start_message: str | None = None
        self._history: list[np.ndarray] = []
        self._history_rows = 0
        self._end_message: str | None = None
        self._system: Any = None
        self._diagrams: dict[frozenset[str], bytes] = {}
        self._marks: list[str] = []  # the condition events fired, as messages
        self._server: Any = None
        self._thread: threading.Thread | None = None
        self._closing = False

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    # -- the server ----------------------------------------------------------------------------
    def start(self) -> str:
        """Bind and serve in a background thread (once); the page's URL."""
        if self._server is not None:
            return self.url
        from twmr.core.extras import require

        require("websockets", "the live view")
        from websockets.sync.server import serve

        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((self.host, self.port))
            sock.listen()
        except OSError as err:
            sock.close()
            raise LiveAddressError(
                f"--live {self.host}:{self.port}: cannot listen there ({err.strerror or err}). "
                f"Fix: choose another port, or --live 0 for a free one.") from None
        self.port = sock.getsockname()[1]
        self._server = serve(self._serve_client, sock=sock, process_request=self._http,
                             compression=None, max_size=2**16, close_timeout=2)
        self._thread = threading.Thread(target=self._server.serve_forever, name="twmr-live",
                                        daemon=True)
        self._thread.start()
        return self.url

    def close(self) -> None:
        """Tell every page the server goes, then stop serving: a page that connects from now on
        is turned away, and one that does not let go within `CLOSE_WAIT` s is left to the
        server's thread (the run never waits on a viewer)."""
        if self._server is None:
            return
        with self._lock:
            self._closing = True
            clients = list(self.clients)
        for client in clients:
            client.push(None)
        drained = threading.Event()
        for _ in range(20):  # at most 1 s for the pages to get what is queued
            with self._lock:
                if not self.clients:
                    break
            drained.wait(0.05)
        with self._lock:
            stuck = list(self.clients)
        for client in stuck:  # a viewer that does not read: its blocked send fails now
            with contextlib.suppress(OSError):
                client.connection.socket.shutdown(socket.SHUT_RDWR)
        stopper = threading.Thread(target=self._server.shutdown, name="twmr-live-close",
                                   daemon=True)
        stopper.start()
        stopper.join(CLOSE_WAIT)
        if stopper.is_alive():
            log.warning("live view: a page did not let go within %g s; left behind", CLOSE_WAIT)
        elif self._thread is not None:
            self._thread.join(timeout=CLOSE_WAIT)
        self._server = None

    def wait(self) -> None:
        """Serve until Ctrl-C (`--live-keep`), then close."""
        stop = threading.Event()
        try:
            while not stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            self.close()

    def _http(self, connection: Any, request: Any) -> Any:
        """The page and its files; a WebSocket upgrade on /ws from this page's origin only."""
        host = request.headers.get("Host", "")
        if not self._host_allowed(host):
            return connection.respond(403, "Forbidden: unexpected Host header.\n")
        path = urlsplit(request.path).path
        if path == "/ws":
            origin = request.headers.get("Origin")
            if origin is not None and urlsplit(origin).netloc != host:
                return connection.respond(403, "Forbidden: another site's page.\n")
            return None
        if path == "/diagram.svg":
            query = parse_qs(urlsplit(request.path).query).get("closed", [""])[0]
            try:
                body = self._diagram_svg(frozenset(n for n in query.split(",") if n))
            except ValueError as err:
                return connection.respond(400, f"{err}\n")
            if body is None:
                return connection.respond(404, "No run has started yet.\n")
            kind = "image/svg+xml; charset=utf-8"
        elif path in _STATIC:
            name, kind = _STATIC[path]
            body = (resources.files("twmr.observers") / "live_static" / name).read_bytes()
        else:
            return connection.respond(404, "Not found.\n")
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        return Response(200, "OK", Headers([("Content-Type", kind),
                                            ("Content-Length", str(len(body))),
                                            ("Cache-Control", "no-store"),
                                            ("Connection", "close")]), body)

    def _diagram_svg(self, closed: frozenset[str]) -> bytes | None:
        """The running system's diagram with the subsystems `closed` drawn as one block each
        (drawn at the first request for them, then kept); ValueError: no such subsystem."""
        with self._lock:
            system, body = self._system, self._diagrams.get(closed)
        if body is None and system is not None:
            from twmr.diagram import closed_subsystems, diagram_svg

            body = diagram_svg(system, str(getattr(system, "source", "")),
                               closed_subsystems(system, closed)).encode("utf-8")
            with self._lock:
                if self._system is system and len(self._diagrams) < DIAGRAMS_KEPT:
                    self._diagrams[closed] = body
        return body

    def _host_allowed(self, host: str) -> bool:
        """On a loopback address only a loopback name or address with this server's port
        (no DNS rebinding: '127.evil.example' is not 127.x.x.x); elsewhere any."""
        if not (self.host.startswith("127.") or self.host in ("::1", "localhost")):
            return True
        name, _, port = host.rpartition(":") if not host.endswith("]") else (host, "", "")
        if not name or port != str(self.port):
            return False
        if name in _LOOPBACK_NAMES:
            return True
        try:
            return ipaddress.ip_address(name.strip("[]")).is_loopback
        except ValueError:
            return False

    def _serve_client(self, connection: Any) -> None:
        from websockets.exceptions import ConnectionClosed

        if str(PurePosixPath(urlsplit(connection.request.path).path)) != "/ws":
            connection.close(1008, "the data is on /ws")
            return
        client = _Client(connection)
        with self._lock:
            closing = self._closing
            if not closing:
                self.clients.append(client)
                control = json.dumps({"type": "control", "paused": True}) \
                    if self.gate is not None and self.gate.paused else None
                first = [m for m in (self._start_message, self._history_frame(), control,
                                     *self._marks, self._end_message) if m is not None]
        if closing:
            connection.close(1001, "the live view closed")
            return
        listener = threading.Thread(target=self._listen, args=(client,), daemon=True,
                                    name="twmr-live-listen")
        listener.start()
        try:
            for message in first:
                connection.send(message)
            while (queued := client.pop()) is not None:
                connection.send(queued)
            connection.close(1001, "the live view closed")
        except ConnectionClosed:
            pass
        finally:
            with self._lock:
                self.clients.remove(client)
                left = not self.clients
            if left and self.gate is not None and self.gate.paused and not self._closing:
                log.warning("live view: the last page left a paused run; it goes on")
                self.gate.resume()

    def _listen(self, client: _Client) -> None:
        """The page's commands (`command`); when it goes, its sender is told to end."""
        from websockets.exceptions import ConnectionClosed

        try:
            for message in client.connection:
                if isinstance(message, str):
                    self.command(message)
        except ConnectionClosed:
            pass
        finally:
            client.push(None)

    def command(self, text: str) -> None:
        """A page's `{"type": "pause" | "resume" | "step", "steps": n}` acted on through the
        gate (none: ignored), and every page told where the run is (`control`); anything else
        is ignored."""
        try:
            message = json.loads(text)
        except ValueError:
            return
        gate = self.gate
        if gate is None or not isinstance(message, dict):
            return
        kind, steps = message.get("type"), message.get("steps", 1)
        if kind == "pause":
            gate.pause()
        elif kind == "resume":
            gate.resume()
        elif kind == "step" and isinstance(steps, int) and 0 < steps <= 10**7:
            gate.grant(steps)
        else:
            return
        self._broadcast(json.dumps({"type": "control", "paused": gate.paused}))

    def _history_frame(self) -> bytes | None:
        if not self._history:
            return None
        return _frame(-1.0, np.concatenate(self._history))

    def _push_all(self, message: str) -> None:
        """`message` to every page (the caller holds the lock)."""
        for client in self.clients:
            client.push(message)

    def _broadcast(self, message: str) -> None:
        with self._lock:
            for client in self.clients:
                client.push(message)

    # -- the observer --------------------------------------------------------------------------
    def started(self, run: RunStart) -> None:
        if self._server is None:
            log.info("live view: %s", self.start())
        columns = list(run.columns)
        units = dict(zip(columns, run.units, strict=True))
        index = {c: i for i, c in enumerate(columns)}
        ports = run.metadata.get("ports", {})
        groups = group_ports(columns)
        planar = [{"port": port, "x": index[cols[0]], "y": index[cols[1]],
                   **({"heading": index[cols[2]], "body": ports.get(port, {}).get("body"),
                       "vectors": [{**v, "index": index[v["column"]]}
                                   for v in ports.get(port, {}).get("vectors", [])]}
                      if len(cols) == 3 else {})}
                  for port, cols in groups.items()
                  if is_planar_position(port, [units[c] for c in cols])]
        labels, stepped = {"time": "time"}, {"time": False}
        for port, cols in groups.items():
            info = ports.get(port, {})
            names = element_names(port, cols, info.get("description", ""))
            for c, n in zip(cols, names, strict=True):
                labels[c] = n if n in (port, c) else f"{port} {n}"
                stepped[c] = info.get("type", "") in STEPWISE_TYPES
        message = json.dumps({"type": "start", "columns": columns, "units": list(run.units),
                              "step": run.step, "n_steps": run.n_steps,
                              "scenario": run.scenario, "ports": ports, "planar": planar,
                              "labels": [labels[c] for c in columns],
                              "stepped": [stepped[c] for c in columns],
                              "diagram": run.system is not None,
                              "control": self.gate is not None,
                              "marks": [{"at": t, "text": text} for t, text in event_marks(
                                  {"events": run.metadata.get("events", [])})]})
        with self._lock:  # a page joining now gets it once: in its first messages or here
            self._start_message, self._end_message = message, None
            self._system, self._diagrams = run.system, {}
            self._history, self._history_rows, self._marks = [], 0, []
            self._push_all(message)

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        if not len(block):
            return
        stride = math.ceil(len(block) / FRAME_ROWS)
        thin = np.array(block[::stride], dtype="<f8")  # a copy: the caller reuses its block
        with self._lock:
            self._keep_history(thin)
            for client in self.clients:
                client.push_rows(thin)

    def _keep_history(self, thin: np.ndarray) -> None:
        self._history.append(thin)
        self._history_rows += len(thin)
        if self._history_rows > HISTORY_ROWS:
            kept = np.concatenate(self._history)[::2]
            self._history, self._history_rows = [kept], len(kept)

    def fired(self, event: dict[str, Any]) -> None:
        """A condition event as a mark on the scopes of every page (and of those that join
        later)."""
        message = json.dumps({"type": "mark", "at": event["at"],
                              "text": f"{event['target']} {event['action']} "
                                      f"({event['when']})"})
        with self._lock:
            self._marks.append(message)
            self._push_all(message)

    def finished(self, outcome: Outcome) -> None:
        message = json.dumps({"type": "end", "status": outcome.status, "error": outcome.error,
                              "steps_done": outcome.steps_done})
        with self._lock:
            self._end_message = message
            self._push_all(message)
        if not self.keep:
            self.close()


def _frame(sequence: float, rows: np.ndarray) -> bytes:
    """A binary rows message: the sequence number, then the rows (float64, row-major)."""
    return np.float64(sequence).astype("<f8").tobytes() + rows.astype("<f8").tobytes()
