"""The C twin of a block (`twmr.core.ctwin.CTwin`, its class's `c_twin`) found by kind.

A block declares its twin as its class attribute `c_twin`, in its own module (e.g. `Gain.c_twin =
CTwin(C / "gain.c", tunable=frozenset({"k", "K"}), ...)`); the twin's C file lives beside it.
"""
from __future__ import annotations

from typing import Any

from twmr.core.component import Component
from twmr.core.ctwin import CTwin
from twmr.core.errors import CosimError
from twmr.registry import kinds, lookup, suggest


def twins() -> dict[str, str]:
    """Every kind whose block has a C twin: kind -> 'module:Class' (each kind's class is
    imported)."""
    found = {}
    for kind, target in kinds().items():
        try:
            cls = lookup(kind)
        except Exception:  # noqa: BLE001 - a kind that does not load has no twin to offer
            continue
        if isinstance(getattr(cls, "c_twin", None), CTwin):
            found[kind] = target
    return found


def twin_of(kind: str) -> CTwin:
    """The C twin of the block of `kind` (its `c_twin`); CosimError naming the kinds that have
    one."""
    try:
        twin = getattr(lookup(kind), "c_twin", None)
    except (KeyError, CosimError, ImportError):
        twin = None
    if not isinstance(twin, CTwin):
        known = twins()
        raise CosimError(f"kind '{kind}' has no C kernel for a standalone FMU"
                         f"{suggest(kind, known)}; these have: {', '.join(sorted(known))}. "
                         f"Fix: export one of them, or use --python for a component of your own "
                         f"(a pythonfmu FMU).")
    return twin


def options_text(comp: Component, twin: CTwin) -> dict[str, Any]:
    """The text and integer parameters the FMU is compiled with (for its description)."""
    return {n: comp.get(n) for n, v in comp.parameters.items()
            if v.type != "Real" and n not in twin.hidden}
