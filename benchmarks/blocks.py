"""µs per block per step of each block kind in the compiled loop, against a hand-written numba
loop of the same chain.

For every registered kind (`twmr.components`) that offers a kernel and has one scalar Real input
and one scalar Real output whose units chain (equal, or one of them unspecified), the chain

    sine -> b1 -> b2 -> ... -> bN          (N = --n blocks of that kind, default parameters)

runs --steps steps of 1 ms (Gauss-Seidel, bN's output recorded every 100 steps), measured in this
one run:

(a) the master with the compiled algorithm (`compiled='on'`): the stepping wall time its outcome
    reports (`Outcome.wall_time`), best of --repeats;
(b) `hand_chain` below: one numba loop over the same kernels (each block evaluated in chain order
    at every point, then each stepped with its input of that point), best of --repeats; its rows
    must equal (a)'s exactly (`rows_identical`).

Compile time is reported apart: `algorithm.compile_s` of (a)'s first run (generating the chain's
loop and compiling it, in a fresh cache folder unless --cached; the blocks' kernels come from
numba's cache when an earlier run compiled them) and the first call of (b). A chain of 100
blocks compiles slowly (issue #29): `--n` makes it shorter, `--kinds` picks kinds. Kinds that
do not fit (no kernel, other ports, units that do not chain) are listed with the reason.

Last line: one JSON object with the figures.
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import tempfile
import time
from typing import Any

import numpy as np
from numba import njit
from numba.typed import List

from twmr.blocks.kernels import sine_step
from twmr.core.kernel import KernelFunction, kernel_function
from twmr.core.port import REAL
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.registry import kinds, lookup
from twmr.scenario import loads

H = 1e-3
DECIMATION = 100
USER_CACHE = os.environ.get("TWMR_CACHE_DIR")


@kernel_function
def _no_evaluate(t: float, x: Any, y: tuple, u: tuple, p: Any) -> tuple[Any, tuple]:
    return x, y


@kernel_function
def _no_step(t: float, h: float, x: Any, y: tuple, u: tuple, p: Any) -> tuple[Any, tuple]:
    return x, y


@njit(cache=True, error_model="numpy")
def hand_chain(n_steps: int, h: float, dec: int, ev: Any, st: Any, p: Any, xs: Any, x0: Any,
               ys: np.ndarray, src_p: Any, src_y: float, buf: np.ndarray) -> int:
    """The chain by hand: block i's output in ys[i], its private state in xs[i] (xs None: the
    kind keeps none, x0 stands for every block's). At each point t the source's output feeds b1,
    each block is evaluated in order (its output the next one's input), the last output is
    recorded every `dec` steps, then the source and every block step from t with the inputs of
    t; returns rows written."""
    n_blocks = len(ys)
    k = 0
    x = x0
    for n in range(n_steps + 1):
        t = n * h
        u = src_y
        for i in range(n_blocks):
            if xs is not None:
                x = xs[i]
            x, y = ev(t, x, (ys[i],), (u,), p)
            if xs is not None:
                xs[i] = x
            ys[i] = y[0]
            u = y[0]
        if n % dec == 0:
            buf[k, 0] = t
            buf[k, 1] = ys[n_blocks - 1]
            k += 1
        if n == n_steps:
            break
        u = src_y
        src_y = sine_step(t, h, (), (src_y,), (), src_p)[1][0]
        for i in range(n_blocks):
            if xs is not None:
                x = xs[i]
            held = ys[i]
            x, y = st(t, h, x, (held,), (u,), p)
            if xs is not None:
                xs[i] = x
            ys[i] = y[0]
            u = held
    return k


def _jit(fn: Any, missing: KernelFunction) -> Any:
    fn = missing if fn is None else fn
    return fn.jit if isinstance(fn, KernelFunction) else fn


def fits(kind: str) -> str:
    """'' when `kind` can form a chain, else why not."""
    try:
        cls = lookup(kind)
    except ImportError as exc:
        return f"not importable ({exc})"
    if not callable(getattr(cls, "kernel", None)):
        return "no kernel"
    proto = cls(kind)
    ins, outs = list(proto.inputs.values()), list(proto.outputs.values())
    if len(ins) != 1 or len(outs) != 1:
        return f"{len(ins)} inputs and {len(outs)} outputs, not one of each"
    u, y = ins[0], outs[0]
    if u.size is not None or y.size is not None or u.type != REAL or y.type != REAL:
        return "input or output not a scalar Real"
    if u.unit and y.unit and u.unit != y.unit:
        return f"units do not chain ({y.unit} out, {u.unit} in)"
    return ""


def chain(kind: str, n: int, steps: int) -> dict[str, Any]:
    """The scenario of the chain of `n` blocks of `kind`."""
    proto = lookup(kind)(kind)
    u, y = next(iter(proto.inputs)), next(iter(proto.outputs))
    names = [f"b{i + 1}" for i in range(n)]
    wires = [f"src.y -> b1.{u}"] + [f"{a}.{y} -> {b}.{u}" for a, b in itertools.pairwise(names)]
    return {"components": {"src": {"kind": "sine", "parameters": {"frequency": 1.0}},
                           **{b: {"kind": kind} for b in names}},
            "connections": wires,
            "experiment": {"start": 0.0, "stop": steps * H, "step": H},
            "record": {"signals": [f"{names[-1]}.{y}"], "decimation": DECIMATION}}


def master_run(spec: dict[str, Any]) -> tuple[np.ndarray, float, float]:
    """(rows, stepping wall time [s], compile time [s]) of the chain, compiled loop."""
    store = ResultStore()
    out = Execution(loads(spec, source="chain.yaml"), [store],
                    algorithm=make_algorithm("gauss_seidel", "on")).run()
    return store.data(), out.wall_time, float(out.extra["algorithm.compile_s"])


def hand_run(spec: dict[str, Any], n: int, steps: int) -> tuple[np.ndarray, float]:
    """(rows, wall time [s]) of `hand_chain` over the chain's initialized blocks."""
    system = loads(spec, source="chain.yaml")
    exp, comps = system.experiment, system.components
    for name in system.order:
        comps[name].setup(exp.start, exp.stop)
        comps[name].initialize()
    src = comps["src"]
    kerns = [comps[f"b{i + 1}"].kernel(H) for i in range(n)]
    first = kerns[0]
    y_port = next(iter(comps["b1"].outputs))
    xs = List([k.state for k in kerns]) if len(first.state) else None
    ys = np.array([float(comps[f"b{i + 1}"].get(y_port)) for i in range(n)])
    buf = np.empty((steps // DECIMATION + 1, 2))
    args = (steps, H, DECIMATION, _jit(first.evaluate, _no_evaluate), _jit(first.step, _no_step),
            first.params, xs, first.state, ys, src.kernel(H).params, float(src.get("y")), buf)
    t0 = time.perf_counter()
    rows = hand_chain(*args)
    return buf[:rows], time.perf_counter() - t0


def measure(kind: str, n: int, steps: int, repeats: int, cached: bool) -> dict[str, Any]:
    """The figures of one kind's chain; the compiled loop's cache a fresh folder unless
    `cached`."""
    spec = chain(kind, n, steps)
    t0 = time.perf_counter()
    hand_rows, _ = hand_run(spec, n, steps)  # compiles hand_chain for this kind
    hand_compile = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="twmr-bench-blocks-") as tmp:
        if not cached:
            os.environ["TWMR_CACHE_DIR"] = tmp
        try:
            return _measure(spec, n, steps, repeats, hand_rows, hand_compile)
        finally:
            os.environ.pop("TWMR_CACHE_DIR", None)
            if USER_CACHE is not None:
                os.environ["TWMR_CACHE_DIR"] = USER_CACHE


def _measure(spec: dict[str, Any], n: int, steps: int, repeats: int, hand_rows: np.ndarray,
             hand_compile: float) -> dict[str, Any]:
    master_rows, wall, compile_s = master_run(spec)
    walls = {"compiled": [wall], "hand": []}
    for i in range(repeats):
        walls["hand"].append(hand_run(spec, n, steps)[1])
        if i:
            walls["compiled"].append(master_run(spec)[1])
    best = {k: min(v) / (steps * n) * 1e6 for k, v in walls.items()}
    return {"compiled_us_per_block_step": round(best["compiled"], 5),
            "hand_us_per_block_step": round(best["hand"], 5),
            "compiled_over_hand": round(best["compiled"] / best["hand"], 2),
            "rows_identical": bool(np.array_equal(hand_rows, master_rows)),
            "compile_s": round(compile_s, 2), "hand_compile_s": round(hand_compile, 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100, help="blocks in each chain (default 100)")
    ap.add_argument("--steps", type=int, default=10_000, help="steps of 1 ms (default 10,000)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--kinds", nargs="*", help="only these kinds (default: every one that fits)")
    ap.add_argument("--cached", action="store_true",
                    help="use the compiled-loop cache (TWMR_CACHE_DIR) instead of a fresh one, "
                         "so compile_s is loading a chain compiled before")
    args = ap.parse_args()
    skipped = {k: why for k in sorted(kinds()) if (why := fits(k))}
    chosen = [k for k in sorted(kinds()) if k not in skipped and (not args.kinds or
                                                                   k in args.kinds)]
    results: dict[str, Any] = {}
    print(f"{'kind':<20}{'compiled us':>12}{'hand us':>10}{'ratio':>7}{'same':>6}"
          f"{'compile s':>11}", flush=True)
    for kind in chosen:
        try:
            r = measure(kind, args.n, args.steps, args.repeats, args.cached)
        except Exception as exc:  # noqa: BLE001 - a kind that fails is reported, the rest run
            results[kind] = {"error": f"{type(exc).__name__}: {exc}"}
            print(f"{kind:<20} failed: {type(exc).__name__}: {exc}", flush=True)
            continue
        results[kind] = r
        print(f"{kind:<20}{r['compiled_us_per_block_step']:>12.4f}"
              f"{r['hand_us_per_block_step']:>10.4f}{r['compiled_over_hand']:>7.2f}"
              f"{'yes' if r['rows_identical'] else 'NO':>6}{r['compile_s']:>11.1f}", flush=True)
    for kind, why in skipped.items():
        print(f"{kind:<20} not chained: {why}")
    print(json.dumps({"blocks_per_chain": args.n, "steps": args.steps, "step_s": H,
                      "units": "us per block per step (best of repeats)", "kinds": results,
                      "not_chained": skipped}))


if __name__ == "__main__":
    main()
