"""The linear, discrete and routing blocks in the compiled loop: a chain of N = 100 blocks of one
kind after a sine, run by the master compiled (`--compiled on`, the loop compiled and cached
before the timing), against a hand-written numba loop of the same chain for three kinds.

Figures: `Outcome.wall_time` (the stepping alone, the last block's output recorded), the best of
two runs, divided by N x steps: µs per block per step. Last line: one JSON object,
{kind: {"us_per_block_step": ..., "hand_us_per_block_step": ... (gain, first_order, pid)}}.

    .venv/bin/python benchmarks/blocks_linear_routing.py [steps]
"""
from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

import numpy as np
from numba import njit

from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import loads

N = 100
H = 1e-3
KINDS: dict[str, str] = {
    "gain": "{k: 0.999}",
    "first_order": "{T: 0.01}",
    "transfer_function": "{num: [1.0, 3.0], den: [0.1, 1.0, 4.0]}",
    "pid": "{kp: 0.5, ki: 1.0, kd: 0.001, N: 100.0, limit_output: true, y_min: -2, y_max: 2,"
           " antiwindup: clamping}",
    "state_space": "{A: [[0, 1], [-2, -3]], B: [0, 1], C: [1, 0]}",
    "zero_order_hold": "{sample_period: 0.004}",
    "transport_delay": "{steps: 3, buffer: 8}",
    "math": "{function: tanh}",
}


def chain(kind: str, params: str, steps: int) -> str:
    comps = ["  b0: {kind: sine, parameters: {frequency: 1.0}}"]
    comps += [f"  b{i}: {{kind: {kind}, parameters: {params}}}" for i in range(1, N + 1)]
    conns = [f"  - b{i - 1}.y -> b{i}.u" for i in range(1, N + 1)]
    return ("components:\n" + "\n".join(comps) + "\nconnections:\n" + "\n".join(conns) +
            f"\nexperiment: {{stop: {steps * H}, step: {H}}}\nrecord: {{signals: [b{N}.y]}}\n")


def master_us(kind: str, steps: int) -> float:
    text = chain(kind, KINDS[kind], steps)
    best = math.inf
    for _ in range(2):
        outcome = Execution(loads(text), [ResultStore()],
                            algorithm=make_algorithm("gauss_seidel", "on")).run()
        best = min(best, outcome.wall_time)
    return best / (N * steps) * 1e6


@njit(cache=True)
def hand_gain(steps: int, k: float) -> float:
    y = np.zeros(N + 1)
    for n in range(steps):
        y[0] = math.sin(2.0 * math.pi * n * H)
        for i in range(1, N + 1):
            y[i] = k * y[i - 1]
    return y[N]


@njit(cache=True)
def hand_first_order(steps: int, a: float) -> float:
    y = np.zeros(N + 1)
    for n in range(steps):
        y[0] = math.sin(2.0 * math.pi * n * H)
        for i in range(1, N + 1):
            y[i] = a * y[i] + (1.0 - a) * y[i - 1]
    return y[N]


@njit(cache=True)
def hand_pid(steps: int, kp: float, ki_h: float, kdn: float, a: float) -> float:
    y = np.zeros(N + 1)
    integral, d, prev = np.zeros(N + 1), np.zeros(N + 1), np.zeros(N + 1)
    for n in range(steps):
        y[0] = math.sin(2.0 * math.pi * n * H)
        for i in range(1, N + 1):
            e = y[i - 1]
            di = a * d[i] + kdn * (e - prev[i])
            v = kp * e + integral[i] + di
            out = min(max(v, -2.0), 2.0)
            gain = ki_h * e
            if out != v and (v - out) * gain > 0.0:
                gain = 0.0
            integral[i] += gain
            d[i], prev[i], y[i] = di, e, out
    return y[N]


def hand_us(kind: str, steps: int) -> float | None:
    calls: dict[str, Any] = {
        "gain": lambda: hand_gain(steps, 0.999),
        "first_order": lambda: hand_first_order(steps, math.exp(-H / 0.01)),
        "pid": lambda: hand_pid(steps, 0.5, 1.0 * H, 0.001 * 100.0, 1.0 - 100.0 * H)}
    if kind not in calls:
        return None
    calls[kind]()  # compiled (or loaded from numba's cache) before the timing
    best = math.inf
    for _ in range(2):
        t0 = time.perf_counter()
        calls[kind]()
        best = min(best, time.perf_counter() - t0)
    return best / (N * steps) * 1e6


def main() -> None:
    steps = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    table: dict[str, dict[str, float | None]] = {}
    print(f"{'kind':<18} {'master µs/block/step':>22} {'hand-written':>14}")
    for kind in KINDS:
        ours, hand = master_us(kind, steps), hand_us(kind, steps)
        table[kind] = {"us_per_block_step": round(ours, 4),
                       "hand_us_per_block_step": None if hand is None else round(hand, 4)}
        print(f"{kind:<18} {ours:>22.4f} {'-' if hand is None else f'{hand:.4f}':>14}")
    print(json.dumps(table))


if __name__ == "__main__":
    main()
