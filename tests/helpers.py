"""Build small `System`s by hand (without a scenario file) for engine tests."""
from __future__ import annotations

from twmr.core.component import Component
from twmr.scenario.system import Connection, Experiment, RecordSpec, System


def wire(text: str) -> Connection:
    """'a.y -> b.u' as a Connection (whole ports)."""
    src, dst = (s.strip() for s in text.split("->"))
    (a, ap), (b, bp) = src.split("."), dst.split(".")
    return Connection(a, ap, b, bp)


def system(components: list[Component], wires: list[str], stop: float, step: float,
           algorithm: str = "gauss_seidel", record: list[str] = (), decimation: int = 1,
           multiples: dict[str, int] | None = None, order: list[str] | None = None) -> System:
    """A System over `components` (execution order = list order unless given)."""
    comps = {c.name: c for c in components}
    rec = tuple(tuple(r.split(".")) for r in record)
    return System(comps, [wire(w) for w in wires], order or list(comps),
                  Experiment(0.0, stop, step, algorithm), RecordSpec(rec, decimation),
                  dict(multiples or {}))
