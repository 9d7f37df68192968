"""Build small `System`s by hand (without a scenario file) for engine tests; process checks."""
from __future__ import annotations

import subprocess
import time

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


def process_group_left(pgid: int, within: float = 60.0) -> str:
    """The processes (pgrep output) still in process group `pgid` after waiting up to `within`
    [s] for them to exit (they may take a moment on a loaded machine); '' when none is left."""
    deadline = time.monotonic() + within
    while True:
        alive = subprocess.run(["pgrep", "-g", str(pgid)], capture_output=True, text=True)
        if not alive.stdout.strip() or time.monotonic() > deadline:
            return alive.stdout.strip()
        time.sleep(0.2)
