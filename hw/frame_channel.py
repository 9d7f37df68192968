"""A CAN frame log (`.blf`, `.asc`, as the drives write it beside the results) read as the
messages of one result channel: registered in the `twmr.frame_logs` entry-point group by its
suffix, so the MCAP export (`twmr.observers.mcap_format`) adds the frames without knowing CAN."""
from __future__ import annotations

from pathlib import Path
from typing import Any

#: the JSON Schema of one frame's message (the channel's `time_s` is added by the export)
SCHEMA: dict[str, Any] = {
    "title": "CAN frame", "type": "object",
    "properties": {
        "time_s": {"type": "number", "unit": "s", "description": "the frame's time on the run's "
                   "time axis [s] (negative: during set-up)"},
        "id": {"type": "integer", "description": "arbitration id"},
        "extended": {"type": "boolean", "description": "29-bit id"},
        "dlc": {"type": "integer", "description": "data length code"},
        "data": {"type": "array", "items": {"type": "integer", "minimum": 0, "maximum": 255}},
        "direction": {"enum": ["rx", "tx"], "description": "as the host saw it"},
        "remote": {"type": "boolean"}, "error_frame": {"type": "boolean"}}}


def frame_messages(path: Path) -> tuple[dict[str, Any], list[tuple[float, dict[str, Any]]]]:
    """(the schema, [(wall-clock time [s since the epoch], message)] of every frame in `path`)."""
    import can

    return SCHEMA, [(frame.timestamp, {
        "id": frame.arbitration_id, "extended": bool(frame.is_extended_id), "dlc": frame.dlc,
        "data": list(frame.data), "direction": "rx" if frame.is_rx else "tx",
        "remote": bool(frame.is_remote_frame), "error_frame": bool(frame.is_error_frame)})
        for frame in can.LogReader(str(path))]
