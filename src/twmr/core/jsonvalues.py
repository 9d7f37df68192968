"""Standard JSON for results: numbers that JSON has none for (NaN, +/-infinity) are the strings
"NaN", "Infinity" and "-Infinity", so every JSON reader (`JSON.parse`, jq) takes our files, and
`revive` turns those strings back into floats when we read them."""
from __future__ import annotations

import json
import math
from typing import Any

NON_FINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


def number(value: float) -> float | str:
    """A finite float as is; NaN and infinities as their strings."""
    if math.isfinite(value):
        return value
    return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")


def plain(value: Any) -> Any:
    """`value` with every float (numpy scalars included) in dicts, lists and tuples made JSON."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()  # numpy scalars
    if isinstance(value, float):
        return number(value)
    return value


def dumps(value: Any, **options: Any) -> str:
    """Standard JSON text of `value` (see the module's docstring)."""
    return json.dumps(plain(value), allow_nan=False, **options)


def revive(value: Any) -> Any:
    """`value` read from such JSON, the strings of non-finite numbers floats again."""
    if isinstance(value, dict):
        return {k: revive(v) for k, v in value.items()}
    if isinstance(value, list):
        return [revive(v) for v in value]
    if isinstance(value, str) and value in NON_FINITE:
        return NON_FINITE[value]
    return value
