"""Component kinds by name, found through the ``twmr.components`` entry-point group.

Like python-can's interface registry: names map to ``module:Class`` strings and a module is imported
only when its kind is used, so hardware libraries load only for scenarios that need them.
"""
from __future__ import annotations

import difflib
import importlib
from functools import lru_cache
from importlib.metadata import entry_points

from twmr.core.component import Component

GROUP = "twmr.components"


@lru_cache(maxsize=1)
def kinds() -> dict[str, str]:
    """All known kinds: name -> 'module:Class'."""
    return {ep.name: ep.value for ep in entry_points(group=GROUP)}


def suggest(name: str, choices: list[str] | tuple[str, ...] | set[str]) -> str:
    """' (did you mean 'x'?)' for the closest choice, or ''."""
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def lookup(kind: str) -> type[Component]:
    """The Component class registered as `kind`; KeyError with a suggestion when unknown."""
    target = kinds().get(kind)
    if target is None:
        raise KeyError(
            f"unknown component kind '{kind}'{suggest(kind, kinds())}; "
            f"known kinds: {', '.join(sorted(kinds()))}"
        )
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)
