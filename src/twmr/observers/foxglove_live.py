"""`FoxgloveServer`: the run's recorded signals live in Foxglove (`twmr run --foxglove`), through
the Foxglove SDK's WebSocket server (`foxglove-sdk`, the extra `foxglove`).

The channels are those of the MCAP export (`twmr.observers.mcap_format`): one per component,
topic `/<component>`, JSON messages with a JSON Schema of its ports and units, log times the
simulated time in nanoseconds; and, as there, `/tf` and the vehicle of each pose whose block
describes it (`twmr.observers.mcap_scene`: Foxglove's 3D panel draws the robot). Open Foxglove,
"Open connection", `ws://127.0.0.1:PORT`. The server binds 127.0.0.1 unless told otherwise; each
client's backlog is bounded (`BACKLOG` messages, the oldest dropped), so the run never waits for
a viewer.
"""
from __future__ import annotations

import logging
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.observers.base import Observer, Outcome, RunStart
from twmr.observers.live import parse_address
from twmr.observers.mcap_format import ComponentChannel, component_channels, log_time_ns
from twmr.observers.mcap_scene import Vehicle, transform, vector_update, vehicle, vehicles

log = logging.getLogger("twmr.live")

#: messages waiting for one client; past it the oldest is dropped
BACKLOG = 4096
#: how often the vehicles' scene is sent again, for clients that join later [ns of run time]
SCENE_EVERY_NS = 1_000_000_000


class FoxgloveServer(Observer):
    """A Foxglove WebSocket server at `address` ('[HOST:]PORT', port 0: a free one) that
    publishes every recorded row on its component's channel."""

    def __init__(self, address: str) -> None:
        self.host, self.port = parse_address(address, "--foxglove")
        self._server: Any = None
        self._context: Any = None
        self._channels: list[tuple[Any, ComponentChannel]] = []
        self._vehicles: list[Vehicle] = []
        self._tf: Any = None
        self._scenes: list[tuple[Any, str, Any]] = []
        self._arrows: list[tuple[Any, str, Any]] = []
        self._scene_due = 0

    def start(self) -> str:
        """Start serving; the address to open in Foxglove."""
        try:
            import foxglove
        except ImportError:
            raise CosimError("--foxglove needs the Foxglove SDK. Fix: pip install "
                             "'foxglove-sdk' (the project's extra 'foxglove').") from None
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(
                name="twmr-cosim", host=self.host, port=self.port, context=self._context,
                message_backlog_size=BACKLOG)
        except Exception as err:  # noqa: BLE001 - the SDK's bind error, in one line
            raise CosimError(f"--foxglove {self.host}:{self.port}: the server cannot start "
                             f"({err}). Fix: choose another port, or 0 for a free one.") from None
        self.port = self._server.port
        return f"ws://{self.host}:{self.port}"

    def started(self, run: RunStart) -> None:
        import foxglove

        if self._server is None:
            log.info("foxglove: %s", self.start())
        self.close_channels()
        self._channels = [
            (foxglove.Channel(c.topic, schema=c.schema, message_encoding="json",
                              context=self._context, metadata={"component": c.owner}), c)
            for c in component_channels(list(run.columns), list(run.units))]
        self._scene_channels(run)

    def _scene_channels(self, run: RunStart) -> None:
        """`/tf` and `/scene/<component>` for each pose whose block describes its vehicle, in
        Foxglove's own schemas (as in result.mcap, `twmr.observers.mcap_scene`)."""
        from foxglove.channels import FrameTransformChannel, SceneUpdateChannel

        self._vehicles = vehicles(list(run.columns), list(run.units),
                                  run.metadata.get("ports", {}))
        self._tf = FrameTransformChannel("/tf", context=self._context) \
            if self._vehicles else None
        self._scenes = [(SceneUpdateChannel(f"/scene/{v.frame}", context=self._context),
                         v.frame, v.body) for v in self._vehicles]
        self._arrows = [(SceneUpdateChannel(f"/scene/{v.frame}/vectors", context=self._context),
                         v.frame, v.vectors) for v in self._vehicles if v.vectors]
        self._scene_due = 0

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        import foxglove.messages as fm

        for row in block:
            stamp = log_time_ns(float(row[0]))
            for channel, layout in self._channels:
                channel.log(layout.message(row), log_time=stamp)
            if self._tf is not None:
                for v in self._vehicles:
                    self._tf.log(transform(v.frame, stamp, *row[v.cols]), log_time=stamp)
            for channel, frame, drawn in self._arrows:
                channel.log(vector_update(frame, drawn, row), log_time=stamp)
            if self._scenes and stamp >= self._scene_due:  # a client that joins gets it soon
                for channel, frame, body in self._scenes:
                    channel.log(fm.SceneUpdate(entities=[vehicle(frame, body)]), log_time=stamp)
                self._scene_due = stamp + SCENE_EVERY_NS

    def finished(self, outcome: Outcome) -> None:
        return

    def close_channels(self) -> None:
        for channel, _ in self._channels:
            channel.close()
        self._channels = []
        for scene, _, _ in self._scenes + self._arrows:
            scene.close()
        if self._tf is not None:
            self._tf.close()
        self._scenes, self._arrows, self._tf = [], [], None

    def close(self) -> None:
        """Stop the server (the channels first)."""
        self.close_channels()
        if self._server is not None:
            self._server.stop()
            self._server = None
