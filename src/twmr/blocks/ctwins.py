"""The C twins of the engine's blocks (c/<kind>.c beside them), registered in the entry-point
group `twmr.c_kernels` for `twmr export KIND` (standalone C FMUs)."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from twmr.blocks import signal_kernels, tables
from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.fmi.cexport.twin import Choice, CTwin

C = Path(__file__).parent / "c"
#: the length of each matrix of a `state_space` block of n states (x0 may also be empty: zeros)
SS_LENGTHS = {"A": lambda n: n * n, "B": lambda n: n, "C": lambda n: n, "x0": lambda n: n}


def state_space_size(comp: Component) -> int:
    """Number of states n of a `state_space` block, its matrices checked (A n*n, C n, x0 n or
    empty: zeros)."""
    n = len(comp.get("B"))
    if n == 0:
        raise CosimError("export state_space: B is empty. Fix: give at least one state.")
    for name, length in SS_LENGTHS.items():
        got, size = len(comp.get(name)), length(n)
        if got != size and not (name == "x0" and got == 0):
            raise CosimError(f"export state_space: {name} has {got} values but B has {n} "
                             f"(expected {size}). Fix: give A as n*n values row by row, B, C "
                             f"and x0 as n values each.")
    return n


def _ss_work(comp: Component) -> int:
    n = state_space_size(comp)
    return n * n + 2 * n + 1


CONSTANT = CTwin(C / "constant.c")
SINE = CTwin(C / "sine.c", tunable=frozenset({"amplitude", "frequency", "phase", "offset"}))
STEP = CTwin(C / "step.c", tunable=frozenset({"height", "time", "offset"}))
GAIN = CTwin(C / "gain.c", tunable=frozenset({"k"}))
SUM = CTwin(C / "sum.c", tunable=frozenset({"k1", "k2"}))
INTEGRATOR = CTwin(C / "integrator.c", tunable=frozenset({"k"}))
DELAY = CTwin(C / "delay.c")
def _ss_pinned(comp: Component) -> frozenset[str]:
    """D = 0 exports a block without feedthrough (y does not depend on u), so D stays 0."""
    return frozenset({"D"}) if comp.get("D") == 0.0 else frozenset()


STATE_SPACE = CTwin(C / "state_space.c", order=state_space_size, order_define="N_SS",
                    lengths=SS_LENGTHS, orders=(1, 2, 3), work=_ss_work, pinned=_ss_pinned)


# -- signal sources and nonlinear blocks (twmr.blocks.signals, twmr.blocks.nonlinear) ----------
def _elements(comp: Component) -> int:
    """The number of elements n of an element-wise block (#defined as N)."""
    return int(comp.get("n"))


def _table_sizes(**lengths: str) -> Callable[[Component], dict[str, int]]:
    """#define -> the length of the table parameter named, after `comp.check` (an export of a
    table of the wrong shape or order is refused as a scenario is)."""
    def sizes(comp: Component) -> dict[str, int]:
        problems = comp.check(frozenset())
        if problems:
            _, message, fix = problems[0]
            raise CosimError(f"export {comp.kind}: {message} Fix: {fix}")
        return {define: len(comp.get(name)) for define, name in lengths.items()}
    return sizes


TABLES_H = C / "tables.h"
EXTRAP_CODES = {f"EXTRAP_{k.upper()}": int(v) for k, v in tables.EXTRAPOLATIONS.items()}
_EXTRAP = {"extrapolation": Choice("EXTRAP", {k: int(v) for k, v in
                                              tables.EXTRAPOLATIONS.items()})}


def _wide(source: Path, **twin: Any) -> CTwin:
    """The twin of an element-wise block: its number of elements #defined as N."""
    return CTwin(source, order=_elements, order_define="N", orders=(1, 3), **twin)


RAMP = CTwin(C / "ramp.c", tunable=frozenset({"slope", "time", "offset"}))
PULSE = CTwin(C / "pulse.c", tunable=frozenset({"amplitude", "width", "delay", "offset"}))
CHIRP = CTwin(C / "chirp.c", tunable=frozenset({"amplitude", "offset"}))
TABLE = CTwin(C / "table.c", headers=(TABLES_H,), defines=EXTRAP_CODES,
              choices={"interpolation": Choice("INTERP_HOLD", {k: int(v) for k, v in
                                                               tables.INTERPOLATIONS.items()})},
              sizes=_table_sizes(N_TABLE="times"))
_DISTRIBUTIONS = {k: int(v) for k, v in signal_kernels.DISTRIBUTIONS.items()}
NOISE = _wide(C / "noise.c", headers=(C / "philox.h",), tunable=frozenset({"mean", "stddev"}),
              defines={f"DIST_{k.upper()}": v for k, v in _DISTRIBUTIONS.items()},
              choices={"distribution": Choice("DIST", _DISTRIBUTIONS)},
              sizes=lambda comp: {"SEED": int(comp.get("seed"))})
SATURATION = _wide(C / "saturation.c", tunable=frozenset({"lower", "upper"}))
DEAD_ZONE = _wide(C / "dead_zone.c", tunable=frozenset({"lower", "upper"}))
QUANTIZER = _wide(C / "quantizer.c", tunable=frozenset({"interval"}))
RATE_LIMITER = _wide(C / "rate_limiter.c", tunable=frozenset({"rising", "falling"}))
BACKLASH = _wide(C / "backlash.c", tunable=frozenset({"width"}), work=_elements)
RELAY = _wide(C / "relay.c", tunable=frozenset({"on_point", "off_point", "on_value",
                                                "off_value"}), work=_elements)
LOOKUP_1D = _wide(C / "lookup_1d.c", headers=(TABLES_H,), defines=EXTRAP_CODES, choices=_EXTRAP,
                  sizes=_table_sizes(N_BP="breakpoints"))
LOOKUP_2D = _wide(C / "lookup_2d.c", headers=(TABLES_H,), defines=EXTRAP_CODES, choices=_EXTRAP,
                  sizes=_table_sizes(N_BP1="breakpoints1", N_BP2="breakpoints2"))
