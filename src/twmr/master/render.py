"""The toolkit every algorithm renders a `Plan` with into Python source: a `Writer` of lines
(each with the block and call it belongs to, for tracebacks), one communication point (`point`:
the Jacobi snapshot, input writes, evaluations and loop solves, guarded by step multiples), the
finite-value check (`finite_check`) and the recording of a row (`record`). The fixed-step schedule
(`twmr.master.schedule`), the adaptive master (`twmr.master.adaptive`) and the generated compiled
loop (`twmr.master.scenario_loop`) use it.
"""
from __future__ import annotations

from collections.abc import Callable

from twmr.master import loops
from twmr.master.algorithm import NonFinite
from twmr.master.plan import Plan, Ref, Signal, Solve, Write, chunks, guard


class Writer:
    """Collects generated lines and the instance (and call) each line belongs to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.owner: dict[int, tuple[str, str]] = {}

    def add(self, indent: int, text: str, owner: tuple[str, str] | None = None) -> None:
        self.lines.append("    " * indent + text)
        if owner is not None:
            self.owner[len(self.lines)] = owner


def tuple_of(items: list[str]) -> str:
    """`(a, b)`, `(a,)` or `()`: a tuple literal of `items`."""
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def point(w: Writer, ind: int, plan: Plan, ids: dict[str, int], ref: Ref,
           final: bool, evaluate: Callable[[str], str | None] | None = None) -> None:
    """Lines of one communication point: the Jacobi snapshot, then the plan's input writes and
    evaluations, each guarded by its component's step multiple (not at the final point);
    `evaluate(name)` writes an evaluation (default: ``ev<i>(t)``; None: no line)."""
    for k, (src, port) in enumerate(plan.snapshot):
        w.add(ind, f"s{k} = {ref(src, port)}")
    for action in plan.point:
        if isinstance(action, Write):
            line, owner = plan.assignment(action, ref), (action.name, "input")
        elif isinstance(action, Solve):
            line, owner = loops.call(action), (", ".join(action.components), "the loop solver")
        else:
            call = f"ev{ids[action.name]}(t)" if evaluate is None else evaluate(action.name)
            if call is None:
                continue
            line, owner = call, (action.name, "evaluate")
        cond = None if final else guard(action)
        w.add(ind, line if cond is None else f"if {cond}: {line}", owner)


#: a vector port held in a local of at most this many elements is summed element by element
#: in the check (shorter than a call of `sum`; the same association)
INLINE_SUM = 4


def finite_check(w: Writer, ind: int, plan: Plan, ref: Ref,
                  local: Callable[[str], bool] = lambda name: False) -> None:
    """One sum over the watched Real outputs; a NaN or Inf in any makes `x - x` non-zero.
    `local(name)`: the ports of component `name` are local variables."""
    if not plan.check:
        return

    def term(s: Signal) -> str:
        r = ref(s.name, s.port)
        if s.size is None:
            return r
        if s.size <= INLINE_SUM and local(s.name):
            return "(" + " + ".join(f"{r}[{k}]" for k in range(s.size)) + ")"
        return f"sum({r})"

    sums = [" + ".join(term(s) for s in chunk) for chunk in plan.check]
    w.add(ind, "x = " + (sums[0] if len(sums) == 1 else sum_of(sums, "0.0")))
    w.add(ind, "if x - x != 0.0: nonfinite(t)")


def sum_of(sums: list[str], zero: str) -> str:
    """`sum(((a + b), (c + d),), zero)`: chunks summed without one deep chained expression."""
    return f"sum(({', '.join(f'({c})' for c in sums)},), {zero})"


def record(w: Writer, ind: int, plan: Plan, ref: Ref, final: bool) -> None:
    """`rows.append(...)` of one flat tuple (t, the recorded values), every `decimation` steps
    (at the final point always); a `Tick` of each recorded Binary port whose clock is True
    (with no clock: always), at every point."""
    for k, b in enumerate(plan.ticks):
        line = f"rows.append(Tick(t, {k}, {ref(b.name, b.port)}))"
        w.add(ind, line if b.clock is None else f"if {ref(*b.clock)}: {line}")
    if not plan.record:
        return
    parts: list[str] = []
    scalars = ["t"]  # consecutive scalars go into one tuple literal
    for s in plan.record:
        if s.size is None:
            scalars.append(ref(s.name, s.port))
            continue
        if scalars:
            parts.append("(" + ", ".join(scalars) + ",)")
            scalars = []
        parts.append(ref(s.name, s.port))
    if scalars:
        parts.append("(" + ", ".join(scalars) + ",)")
    pieces = [" + ".join(c) for c in chunks(parts)]
    line = f"rows.append({pieces[0] if len(pieces) == 1 else sum_of(pieces, '()')})"
    if final or plan.decimation == 1:
        w.add(ind, line)
    else:
        w.add(ind, f"if n % {plan.decimation} == 0: {line}")


def nonfinite(t: float) -> None:
    """What a generated `if x - x != 0.0: nonfinite(t)` calls."""
    raise NonFinite(t)
