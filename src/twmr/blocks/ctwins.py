"""The C twins of the engine's blocks (c/<kind>.c beside them), registered in the entry-point
group `twmr.c_kernels` for `twmr export KIND` (standalone C FMUs)."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from twmr.blocks import signal_kernels, tables
from twmr.blocks.discrete import TF_METHODS
from twmr.blocks.discrete_kernels import ANTIWINDUP
from twmr.blocks.routing_kernels import EXP_MAX, FUNCTIONS
from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.fmi.cexport.twin import Choice, CTwin

C = Path(__file__).parent / "c"
#: the length of each matrix of a single-input single-output `state_space` block of n states (x0
#: may also be empty: zeros)
SS_LENGTHS = {"A": lambda n: n * n, "B": lambda n: n, "C": lambda n: n, "x0": lambda n: n}


def state_space_size(comp: Component) -> int:
    """Number of states n of a `state_space` block, its matrices checked (`StateSpace.order`)."""
    try:
        return int(comp.order())  # type: ignore[attr-defined]
    except ValueError as err:
        raise CosimError(f"export state_space: {err}") from None


def _ss_work(comp: Component) -> int:
    n = state_space_size(comp)
    return n * n + n * comp.get("n_in") + n + 1


CONSTANT = CTwin(C / "constant.c")
SINE = CTwin(C / "sine.c", tunable=frozenset({"amplitude", "frequency", "phase", "offset"}))
STEP = CTwin(C / "step.c", tunable=frozenset({"height", "time", "offset"}))


def checked(comp: Component) -> Component:
    """`comp`, its parameters checked as `twmr check` does (CosimError for the first problem)."""
    for _key, message, fix in comp.check(frozenset()):
        raise CosimError(f"export {comp.kind}: {message} Fix: {fix}")
    return comp


def _gain(comp: Component) -> dict[str, int | str]:
    checked(comp)
    return {"GAIN_MATRIX": int(bool(comp.get("K"))), "N_IN": comp.get("n_in"),
            "N_OUT": comp.get("n_out")}


GAIN = CTwin(C / "gain.c", tunable=frozenset({"k", "K"}), sizes=_gain)
SUM = CTwin(C / "sum.c", tunable=frozenset({"k1", "k2"}),
            sizes=lambda comp: _nary("SUM", "signs", "+-")(comp))
INTEGRATOR = CTwin(C / "integrator.c", tunable=frozenset({"k"}))
DELAY = CTwin(C / "delay.c")
def _ss_pinned(comp: Component) -> frozenset[str]:
    """D = 0 exports a block without feedthrough (y does not depend on u), so D stays 0."""
    return frozenset() if comp.has_feedthrough else frozenset({"D"})


STATE_SPACE = CTwin(C / "state_space.c", order=state_space_size, order_define="N_SS",
                    lengths=SS_LENGTHS, orders=(1, 2, 3), work=_ss_work, pinned=_ss_pinned,
                    headers=(C / "expm.h",),
                    sizes=lambda comp: {"N_IN": comp.get("n_in"), "N_OUT": comp.get("n_out")})


def _width(comp: Component, name: str) -> int:
    return comp.variables[name].width


def _initialiser(values: list[float] | list[int]) -> str:
    return "{" + ", ".join(map(repr, values)) + "}"


def _tf_order(comp: Component) -> int:
    return len(checked(comp).get("den")) - 1


def _tf_work(comp: Component) -> int:
    n = _tf_order(comp)
    return 2 * n * n + 4 * n + 2


def _pid_pinned(comp: Component) -> frozenset[str]:
    """kp = kd = 0 exports a block without feedthrough, so they stay 0."""
    return frozenset() if comp.has_feedthrough else frozenset({"kp", "kd"})


def _nary(prefix: str, ops: str, alphabet: str) -> Callable[[Component], dict[str, int | str]]:
    def computed(comp: Component) -> dict[str, int | str]:
        signs = [1.0 if c == alphabet[0] else -1.0 for c in comp.get(ops)]
        return {f"{prefix}_N": len(signs), f"{prefix}_W": _width(comp, "y"),
                f"{prefix}_{ops.upper()}": _initialiser(signs)}
    return computed


def _selector(comp: Component) -> dict[str, int | str]:
    width, index = comp.get("width"), comp.get("indices")
    if not index or not all(1 <= i <= width for i in index):
        raise CosimError(f"export selector: indices {list(index)} name elements outside 1 .. "
                         f"{width}. Fix: give indices from 1 to the input's width.")
    return {"SEL_M": len(index), "SEL_INDEX": _initialiser([i - 1 for i in index])}


TRANSFER_FUNCTION = CTwin(
    C / "transfer_function.c", headers=(C / "expm.h",), order=_tf_order, order_define="TF_N",
    choices={"method": Choice("TF_METHOD", {m: TF_METHODS[m] for m in ("zoh", "discrete")})},
    sizes=lambda comp: {"NUM_LEN": len(comp.get("num"))}, work=_tf_work)
PID = CTwin(C / "pid.c", tunable=frozenset({"kp", "ki", "kd", "N", "kb", "y_min", "y_max"}),
            choices={"antiwindup": Choice("PID_AW", ANTIWINDUP),
                     "limit_output": Choice("PID_LIMIT", {False: 0, True: 1})},
            work=lambda comp: 4, pinned=_pid_pinned)
TRANSPORT_DELAY = CTwin(
    C / "transport_delay.c",
    sizes=lambda comp: {"TD_N": comp.get("n"), "TD_B": comp.get("buffer"),
                           "TD_STEPS": comp.get("steps")},
    work=lambda comp: comp.get("buffer") * comp.get("n") + 2)
ZERO_ORDER_HOLD = CTwin(C / "zero_order_hold.c", tunable=frozenset({"sample_period"}),
                        sizes=lambda comp: {"N_EL": comp.get("n")})
FIRST_ORDER = CTwin(C / "first_order.c", tunable=frozenset({"K", "T"}),
                    sizes=lambda comp: {"N_EL": comp.get("n")})
MUX = CTwin(C / "mux.c", sizes=lambda comp: {"MUX_LEN": _width(comp, "y")})
DEMUX = CTwin(C / "demux.c", sizes=lambda comp: {"MUX_LEN": _width(comp, "u")})
SELECTOR = CTwin(C / "selector.c", sizes=_selector)
PRODUCT = CTwin(C / "product.c", sizes=_nary("PROD", "ops", "*/"))
MATH = CTwin(C / "math.c", choices={"function": Choice("MATH_FN", FUNCTIONS)},
             sizes=lambda comp: {"N_EL": comp.get("n"), "EXP_MAX": repr(EXP_MAX)})



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
