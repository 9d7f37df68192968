"""The C twins of the engine's blocks (c/<kind>.c beside them), registered in the entry-point
group `twmr.c_kernels` for `twmr export KIND` (standalone C FMUs)."""
from __future__ import annotations

from pathlib import Path

from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.fmi.cexport.twin import CTwin

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
