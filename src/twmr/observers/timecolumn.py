"""Which column of a file another tool wrote is its time."""
from __future__ import annotations

from collections.abc import Iterable

#: names a time column goes by, first found first
TIME_NAMES = ("time", "t", "Time", "TIME")


def time_column(names: Iterable[str]) -> str | None:
    """The column of `names` that is the time: one named as `TIME_NAMES` says, else a struct's
    field of that name ('yout.time'); None if none is."""
    names = list(names)
    return next((n for n in TIME_NAMES if n in names), None) or next(
        (n for n in names if n.rsplit(".", 1)[-1] in TIME_NAMES), None)
