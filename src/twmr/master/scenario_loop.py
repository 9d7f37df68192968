"""The loop generated for one system (the second form of `twmr.master.compiled`): every port
value a local variable, one call per block, compiled with numba per scenario, FMUs called through
their C functions (`twmr.fmi.compiled_calls`). `kernels_of` gathers the components' kernels (or
says why not), `kinds_of` their kinds for the driver, `generate` writes the loop's source over
the plan, `held_loop` keeps it on the system (loaded once, compiled once), `own_loop` decides
when a system the driver can run takes its own loop instead; the module is written to the cache
folder (`cache_dir`) so numba's cache holds across processes (`twmr.master.schedule_cache`).
"""
from __future__ import annotations

import logging
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.component import replaced_on_instance
from twmr.core.kernel import Carriage, Kernel
from twmr.core.port import CLOCK, TEXT_TYPES
from twmr.master import driver
from twmr.master.plan import Plan, Solve, Write, advancing, guard
from twmr.master.render import Writer, tuple_of
from twmr.scenario.system import System

log = logging.getLogger("twmr.run")


def cache_dir() -> Path:
    """Where the generated modules (and numba's cache of them) are kept."""
    env = os.environ.get("TWMR_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "twmr" / "schedules"


def port_value(var: Any, value: Any, kind: Carriage) -> Any:
    """A port's value as the compiled loop holds it (`kind` from `carriage_of`): a float, an
    int64 or a uint64 (wrapped into its range), a tuple of them, or 0.0 for a port the loop
    does not carry."""
    if kind == Carriage.NONE:
        return 0.0
    if var.size is None:
        return _number(value, kind)
    return tuple(_number(v, kind) for v in value)


def _number(value: Any, kind: Carriage) -> Any:
    if kind == Carriage.FLOAT:
        return float(value)
    if kind == Carriage.UINT:
        return np.uint64(int(value) % 2**64)
    return np.int64((int(value) + 2**63) % 2**64 - 2**63)


def carriage_of(system: System, kernels: dict[str, Kernel]) -> dict[tuple[str, str], Carriage]:
    """How the loop carries each port (`Carriage`; an FMU's by `compiled_calls.carried`, an
    integer input as its source, so it holds the same value; NONE: a String, Binary or Clock
    port of an FMU that the run neither sets nor reads)."""
    from twmr.fmi.compiled_calls import carried

    out: dict[tuple[str, str], Carriage] = {}
    for name in system.order:
        comp = system.components[name]
        fmu = kernels[name].fmu
        fmi = {p.name: p.fmi_type for p in getattr(comp, "ports", ())} if fmu else {}
        for port, var in {**comp.outputs, **comp.inputs}.items():
            out[name, port] = Carriage.NONE if var.type in (*TEXT_TYPES, CLOCK) else \
                carried(fmi.get(port, "Real"), bool(fmu and fmu.fmi3)) if var.type != "Real" \
                else Carriage.FLOAT
    for conn in system.connections:
        dst = (conn.dst, conn.dst_port)
        if out[dst] in (Carriage.INT, Carriage.UINT, Carriage.BOOL) and \
                conn.dst_index is None and conn.src_index is None:
            out[dst] = out[conn.src, conn.src_port]
    return out


#: the kinds of variable that are ports (`Component.inputs` and `Component.outputs`)
PORTS = ("input", "output", "state")


def kernels_of(system: System, record: list[tuple[str, str]], fmus: bool
               ) -> tuple[dict[str, Kernel] | None, str]:
    """Every component's kernel, or None and why not; FMU blocks get one (their compiled calls)
    when `fmus` (mode 'on': in 'auto' an FMU keeps the Python loop, where a call that hangs is
    named on a stop signal and a crash inside the FMU loses at most a short chunk of rows)."""
    from twmr.fmi.compiled_calls import NotCompilable

    comps = system.components
    for name, port in record:
        if comps[name].variables[port].kind not in ("input", "output", "state"):
            return None, f"'{name}.{port}' is recorded but is not a port"
    kernels: dict[str, Kernel] = {}
    h = system.experiment.step
    for name in system.order:
        comp = comps[name]
        make = getattr(comp, "kernel", None)
        if make is None and fmus:
            make = getattr(comp, "compiled_calls", None)
        if replaced_on_instance(comp):
            return None, f"'{name}' has its methods replaced on the instance"
        owner = next((k for k in type(comp).__mro__ if "kernel" in vars(k)), None)
        if owner is not None and any(getattr(type(comp), m) is not getattr(owner, m)
                                     for m in ("evaluate", "do_step")):
            return None, f"'{name}' ({type(comp).__name__}) overrides the methods its " \
                         f"kernel mirrors"
        try:
            kern = make(system.multiple(name) * h) if make is not None else None
        except NotCompilable as exc:
            return None, str(exc)
        if kern is None and make is None and hasattr(comp, "compiled_calls"):
            return None, f"'{name}' is an FMU, which the compiled loop calls only with " \
                         f"--compiled on (in auto it keeps the Python loop, where a call that " \
                         f"hangs is named and a crash inside the FMU loses at most a short " \
                         f"chunk of rows)"
        if kern is None:
            return None, f"'{name}' ({type(comp).__name__}) offers no compiled kernel " \
                         f"with these parameters"
        if kern.fmu is None and any(v.type != "Real" and v.kind in PORTS
                                    for v in comp.variables.values()):
            port, var = next((p, v) for p, v in {**comp.inputs, **comp.outputs}.items()
                             if v.type != "Real")
            return None, f"port '{name}.{port}' is {var.type}, not Real"
        if kern.evaluate is None and kern.fmu is None and comp.has_feedthrough:
            return None, f"'{name}' has feedthrough but its kernel no evaluate"
        kernels[name] = kern
    return kernels, ""


def kinds_of(system: System, kernels: dict[str, Kernel]) -> dict[str, driver.KindSpec] | None:
    """Every component's kind for the driver, or None: a value the driver cannot hold, or an
    FMU call it does not carry (the generated loop then runs it)."""
    try:
        return {n: driver.kind_of(system.components[n], kernels[n]) for n in system.order}
    except driver.Unsupported as exc:
        log.debug("compiling the loop of this scenario (not the driver): %s", exc)
        return None



def generate(system: System, plan: Plan, kernels: dict[str, Kernel],
              kinds: dict[tuple[str, str], Carriage]) -> tuple[str, dict[str, Any]]:
    """(source, {name: kernel function}) of `run(n0, n1, start, h, H, P, X, Y, U, buf, dec)` and
    `finish(n, start, h, P, X, Y, U, buf)` rendered from `plan` over `kernels`; both return (X, Y,
    U, rows written, the step of a NaN/Inf or of a failed FMU call or -1, `compiled_calls.CALLS` *
    component index + the call's index (`compiled_calls.call_names`) of that failure or -1, its
    status). Port values are carried as `kinds` says; a Real input written from an Integer or
    Boolean source gets the source's value as a float."""
    from twmr.fmi.compiled_calls import call_lines

    comps = system.components
    order = plan.order
    ids = {name: i for i, name in enumerate(order)}
    outs = {n: list(comps[n].outputs) for n in order}
    ins = {n: list(comps[n].inputs) for n in order}
    names: dict[str, Any] = {}
    for name in order:
        i, k = ids[name], kernels[name]
        if k.evaluate is not None:
            names[f"ev{i}"] = k.evaluate
        if k.step is not None:
            names[f"st{i}"] = k.step
    lean = {n for n in advancing(system, plan) if kernels[n].advance is not None}
    for name in lean:
        names[f"ad{ids[name]}"] = kernels[name].advance

    def local(name: str, port: str) -> str:
        if port in outs[name]:
            return f"y{ids[name]}_{outs[name].index(port)}"
        return f"u{ids[name]}_{ins[name].index(port)}"

    def call(name: str, fn: str, args: str) -> list[str]:
        fmu = kernels[name].fmu
        if fmu is not None:
            return call_lines(fmu, ids[name], None if fn == "ev" else args,
                              not comps[name].has_feedthrough, lambda p: local(name, p),
                              lambda p: comps[name].variables[p].size is None)
        i = ids[name]
        ys = [f"y{i}_{k}" for k in range(len(outs[name]))]
        us = [f"u{i}_{k}" for k in range(len(ins[name]))]
        lines = [f"r = {fn}{i}({args}, x{i}, {tuple_of(ys)}, {tuple_of(us)}, p{i})",
                 f"x{i} = r[0]"]
        lines += [f"{y} = r[1][{k}]" for k, y in enumerate(ys)]
        return lines

    def write(action: Write) -> str:
        text = plan.assignment(action, local)
        if kinds[action.name, action.port] == Carriage.FLOAT and \
                comps[action.name].variables[action.port].size is None and \
                any(kinds[s] != Carriage.FLOAT for s in action.sources):
            cur, value = text.split(" = ", 1)
            return f"{cur} = float({value})"
        return text

    def point(w: Writer, ind: int, final: bool) -> None:
        for k, (src, port) in enumerate(plan.snapshot):
            w.add(ind, f"s{k} = {local(src, port)}")
        for action in plan.point:
            assert not isinstance(action, Solve), "a loop to solve is refused before"
            lines = [write(action)] if isinstance(action, Write) \
                else call(action.name, "ev", "t")
            cond = None if final else guard(action)
            if cond is not None:
                w.add(ind, f"if {cond}:")
            for line in lines:
                w.add(ind + (cond is not None), line)

    def check(w: Writer, ind: int, then: str) -> None:
        if not plan.check:
            return
        # the association of the Python schedule's `sum(port) + ...`, chunk by chunk
        sums = [" + ".join("(" + (" + ".join(f"{local(s.name, s.port)}[{k}]"
                                             for k in range(s.size))
                                  if s.size is not None else local(s.name, s.port)) + ")"
                           for s in chunk) for chunk in plan.check]
        if len(sums) == 1:
            w.add(ind, "v = " + sums[0])
        else:
            w.add(ind, "v = 0.0")
            for chunk_sum in sums:
                w.add(ind, f"v = v + ({chunk_sum})")
        w.add(ind, f"if v - v != 0.0: {then}")

    def rec(w: Writer, ind: int) -> None:
        if not plan.record:
            return
        w.add(ind, "buf[k, 0] = t")
        col = 1
        for s in plan.record:
            v = local(s.name, s.port)
            if s.size is None:
                w.add(ind, f"buf[k, {col}] = {v}")
                col += 1
            else:
                for e in range(s.size):
                    w.add(ind, f"buf[k, {col}] = {v}[{e}]")
                    col += 1
        w.add(ind, "k += 1")

    def unpack(w: Writer) -> None:
        for name in order:
            i = ids[name]
            w.add(1, f"x{i} = X[{i}]")
            w.add(1, f"p{i} = P[{i}]")
            for k in range(len(outs[name])):
                w.add(1, f"y{i}_{k} = Y[{i}][{k}]")
            for k in range(len(ins[name])):
                w.add(1, f"u{i}_{k} = U[{i}][{k}]")
        w.add(1, "k = 0")
        w.add(1, "bad = -1")
        w.add(1, "fail = -1")
        w.add(1, "fstat = 0")

    def pack(w: Writer) -> None:
        xs = tuple_of([f"x{ids[n]}" for n in order])
        ys = tuple_of([tuple_of([f"y{ids[n]}_{k}" for k in range(len(outs[n]))]) for n in order])
        us = tuple_of([tuple_of([f"u{ids[n]}_{k}" for k in range(len(ins[n]))]) for n in order])
        w.add(1, f"return {xs}, {ys}, {us}, k, bad, fail, fstat")

    def steps(w: Writer, ind: int, lean: set[str]) -> None:
        for st in plan.steps:
            if kernels[st.name].step is None and kernels[st.name].fmu is None:
                continue
            fn = "ad" if st.name in lean else "st"
            lines = call(st.name, fn, f"{st.time}, h{ids[st.name]}")
            if st.guard is not None:
                w.add(ind, f"if {st.guard}:")
            for line in lines:
                w.add(ind + (st.guard is not None), line)

    w = Writer()
    w.add(0, f"# generated by twmr.master.compiled: {plan.method}")
    for name in order:
        w.add(0, f"# component {ids[name]}: {name} ({type(comps[name]).__name__})")
    w.add(0, "from numba import njit")
    if any(k.fmu is not None for k in kernels.values()):
        w.add(0, "from numpy import float64, int64, uint64")
    for key, fn in names.items():
        w.add(0, f"from {fn.__module__} import {fn.__qualname__} as {key}")
    w.add(0, "")
    w.add(0, "")
    w.add(0, "@njit(cache=True, error_model='numpy', nogil=True)")
    w.add(0, "def run(n0, n1, start, h, H, P, X, Y, U, buf, dec):")
    unpack(w)
    for name in order:
        w.add(1, f"h{ids[name]} = H[{ids[name]}]")
    w.add(1, "for n in range(n0, n1):")
    w.add(2, "t = start + n * h")
    point(w, 2, final=False)
    check(w, 2, "bad = n; break")
    if plan.record:
        w.add(2, "if n % dec == 0:")
        rec(w, 3)
    if lean:  # the last step of a call whole, as the driver's chunks end
        w.add(2, "if n != n1 - 1:")
        steps(w, 3, lean)
        w.add(2, "else:")
    steps(w, 3 if lean else 2, set())
    pack(w)
    w.add(0, "")
    w.add(0, "")
    w.add(0, "@njit(cache=True, error_model='numpy', nogil=True)")
    w.add(0, "def finish(n, start, h, P, X, Y, U, buf):")
    unpack(w)
    w.add(1, "t = start + n * h")
    w.add(1, "for _ in range(1):  # a block to break out of")
    point(w, 2, final=True)
    check(w, 2, "bad = n; break")
    rec(w, 2)
    pack(w)
    return "\n".join(w.lines) + "\n", names


def writes_of(system: System, carried: dict[tuple[str, str], Carriage]) -> list[tuple[Any, ...]]:
    """Per component of the system's order, how `CompiledStep._sync` writes the loop's port
    values back, for its outputs and for its inputs: (names, None) when it writes every one as
    the loop holds it, else (names, ((port, index, as a bool), ...)) of those it writes."""
    out = []
    for name in system.order:
        comp, row = system.components[name], []
        for ports in (comp.outputs, comp.inputs):
            kinds = [carried[name, p] for p in ports]
            some = None if all(k not in (Carriage.NONE, Carriage.BOOL) for k in kinds) else tuple(
                (p, j, k == Carriage.BOOL) for j, (p, k) in enumerate(zip(ports, kinds,
                                                                           strict=True))
                if k != Carriage.NONE)
            row.append((tuple(ports), some))
        out.append(tuple(row))
    return out


#: where `held_loop` keeps a system's loop
HELD_LOOP = "_twmr_held_loop"


class HeldLoop:
    """A system's generated loop (`generate`): its source, kernel functions and port carriage,
    for the plan and kernel functions it was made for, and `run`/`finish` once loaded; `typed`:
    compiled for the system's argument types (a later run with other types compiles on call)."""

    def __init__(self, system: System, plan: Plan, key: tuple, source: str,
                 names: dict[str, Any], carried: dict[tuple[str, str], Carriage]):
        self.plan, self.key, self.source, self.names, self.carried = plan, key, source, names, \
            carried
        self.loaded: tuple[Any, Any] | None = None
        self.cached: bool | None = None
        self._asked = 0.0  # when `cached` was asked [s, time.monotonic]
        self._claim: Any = None  # the lock on compiling the loop (`claim`)
        self.typed = False
        self.writes = writes_of(system, carried)

    def functions(self) -> tuple[Any, Any]:
        """(run, finish), loaded on first use (`_load`)."""
        if self.loaded is None:
            self.loaded = _load(self.source, self.names)
        return self.loaded

    def in_cache(self) -> bool:
        """Whether the loop's machine code is at hand without compiling: loaded by this process
        or in numba's cache (a 'no' is asked again after `RECHECK_S`: another process may
        have compiled it since)."""
        if self.cached is None or (not self.cached and
                                   time.monotonic() - self._asked >= RECHECK_S):
            from twmr.master import schedule_cache

            self._asked = time.monotonic()
            self.cached = self.loaded is not None or (
                self._shared() and
                schedule_cache.has_machine_code(self.source, self.names, cache_dir()))
        return self.cached

    def claim(self) -> bool:
        """Take the lock on compiling the loop (`schedule_cache.claim`, held until `release`):
        False while another process holds it, i.e. compiles the loop into the cache folder,
        where this process finds it later (`in_cache`). A loop compiled per process
        (a kernel not importable) needs no lock."""
        if self._claim is None:
            from twmr.master import schedule_cache

            self._claim = schedule_cache.claim(self.source, self.names, cache_dir()) \
                if self._shared() else True
        return self._claim is not None

    def release(self) -> None:
        """Let go of the lock on compiling the loop (`claim`), if held."""
        if self._claim is not None and self._claim is not True:
            self._claim.close()
        self._claim = None

    def _shared(self) -> bool:
        """Whether the loop is compiled into the cache folder, for every process."""
        return all(_importable(fn) for fn in self.names.values())


def held_loop(system: System, plan: Plan, kernels: dict[str, Kernel]) -> HeldLoop:
    """The loop generated for `system` under `plan` over `kernels`, kept on the system and
    handed out again (loaded once, compiled once) for the same plan object
    (`plan.held_build`: the same variables and wires), kernel functions and FMU calls (what
    the port carriage, `carriage_of`, depends on besides), as for a built system run again with
    other values (`twmr.build`)."""
    key = tuple((k.evaluate, k.step, k.advance, k.fmu) for k in (kernels[n] for n in plan.order))
    held = system.__dict__.get(HELD_LOOP)
    if held is None or held.plan is not plan or held.key != key:
        carried = carriage_of(system, kernels)
        source, names = generate(system, plan, kernels, carried)
        held = system.__dict__[HELD_LOOP] = HeldLoop(system, plan, key, source, names,
                                                            carried)
    return held


#: what taking a system's own loop costs [s] in a process that has run the system (its kernels
#: loaded and in numba's cache): loaded from numba's cache, compiled afresh (the paper
#: scenario's: 0.02-0.03 s and 2.1-2.5 s, `benchmarks/compiled_schedule.py`: `own_loop_load_s`,
#: `own_loop_compile_s`)
OWN_LOOP_LOAD_S, OWN_LOOP_COMPILE_S = 0.03, 2.5
#: how long a process runs the driver before asking numba's cache again for a loop it did not
#: find there [s]
RECHECK_S = 1.0
#: the part of the driver's stepping time a system's own loop saves, at least (the paper
#: scenario's: 0.270 against 0.352 us a step, `benchmarks/compiled_schedule.py`)
OWN_LOOP_SAVING = 0.2


def own_loop(system: System, plan: Plan, kernels: dict[str, Kernel]) -> HeldLoop | None:
    """The loop generated for a system the driver can run, when the system takes it instead:
    its `own_loop_budget_s` covers loading it when numba's cache (or this process) holds it,
    or compiling it, unless another process is compiling it (`HeldLoop.claim`: the driver
    runs until that process has put it in the cache); else None (a loop that cannot be made
    too). A system with FMUs takes it only from the cache: compiling its loop grows faster
    than the square of the number of FMUs (`benchmarks/fmu_compile.py`), which the budget's
    price does not know."""
    budget = system.own_loop_budget_s
    if budget < OWN_LOOP_LOAD_S:
        return None
    try:
        loop = held_loop(system, plan, kernels)
    except Exception:  # noqa: BLE001 - a loop that cannot be made: the driver runs
        return None
    if loop.in_cache():
        return loop
    if any(k.fmu is not None for k in kernels.values()):
        return None
    return loop if budget >= OWN_LOOP_COMPILE_S and loop.claim() else None


def _importable(fn: Any) -> bool:
    mod = sys.modules.get(getattr(fn, "__module__", ""), None)
    name = getattr(fn, "__qualname__", "<none>")
    return mod is not None and getattr(mod, name, None) is fn and "<" not in name


def _load(source: str, names: dict[str, Any]) -> tuple[Any, Any]:
    """(run, finish) from `source`: as a module file in the cache folder, verified, so numba's
    cache holds across processes (`twmr.master.schedule_cache`), when every kernel is
    importable; else exec'd, compiled per process."""
    if all(_importable(fn) for fn in names.values()):
        from twmr.master import schedule_cache

        try:
            return schedule_cache.load(source, names, cache_dir())
        except OSError as exc:  # a cache folder we cannot write: compile in this process
            log.debug("schedule cache not usable (%s); compiling without it", exc)
    env: dict[str, Any] = dict(names)
    body = "\n".join(line for line in source.splitlines()
                     if not line.startswith("from ") or line.startswith(("from numba",
                                                                         "from numpy")))
    exec(compile(body.replace("cache=True", "cache=False"),  # noqa: S102 - generated here
                 "<twmr compiled schedule>", "exec"), env)
    return env["run"], env["finish"]
