"""Blocks whose number of ports follows a parameter (a sum of n inputs, a mux, a demux): the
numbered ports u1, u2, ... re-declared on the instance when the parameter changes."""
from __future__ import annotations

import dataclasses

from twmr.core.component import Component
from twmr.core.port import Variable


def numbered(comp: Component, prefix: str, count: int, proto: Variable,
             size: int | None) -> None:
    """Declare `comp`'s ports prefix1 .. prefix<count> like `proto` with `size` (None: scalar),
    in place of the present ones (the others keep their order; new values start at the start
    value)."""
    first = proto.start[0] if isinstance(proto.start, tuple) else proto.start
    start = first if size is None else (first,) * size
    names = [f"{prefix}{i}" for i in range(1, count + 1)]
    old = comp.variables
    at = next((i for i, k in enumerate(old) if _is_numbered(k, prefix)), len(old))
    rest = [(k, v) for k, v in old.items() if not _is_numbered(k, prefix)]
    made = []
    for name in names:
        var = old.get(name)
        if var is None or var.size != size:
            var = dataclasses.replace(proto, size=size, start=start)
            var.name = name
            comp.__dict__[name] = start
        made.append((name, var))
    comp.variables = dict(rest[:at] + made + rest[at:])


def _is_numbered(key: str, prefix: str) -> bool:
    return key.startswith(prefix) and key[len(prefix):].isdigit()


def resized(var: Variable, size: int | None) -> Variable:
    """`var` with `size` (None: scalar), its start value repeated."""
    first = var.start[0] if isinstance(var.start, tuple) else var.start
    out = dataclasses.replace(var, size=size, start=first if size is None else (first,) * size)
    out.name = var.name
    return out
