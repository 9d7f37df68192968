"""One plan, two loops (`twmr.master.plan`): the Python schedule and the compiled loop chunk the
NaN/Inf check the same way, so a sum that overflows in one association and not in the other
cannot tell them apart."""
from __future__ import annotations

import math

import numpy as np

from tests.helpers import system
from twmr.blocks import Constant
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.master.plan import CHAIN, build
from twmr.observers.store import ResultStore

#: +max at the last term of the first chunk and at the first of the second, -max after it:
#: summed chunk by chunk the check is finite (max + (max - max)); summed in one chain, or cut
#: anywhere else, it overflows to inf and the run would stop as non-finite
BIG = 1.0e308
VALUES = [0.0] * (CHAIN - 1) + [BIG, BIG, -BIG] + [0.0] * 4


def many_constants() -> object:
    blocks = [Constant(f"c{k}", value=v) for k, v in enumerate(VALUES)]
    return system(blocks, [], stop=0.01, step=0.001, record=[f"c{k}.y" for k in
                                                              range(len(VALUES))])


def test_the_check_is_cut_into_chunks_of_chain_terms() -> None:
    sysm = many_constants()
    plan = build(sysm, "gauss_seidel", list(sysm.record.signals), 1)
    assert [len(c) for c in plan.check] == [CHAIN, len(VALUES) - CHAIN]
    assert math.isinf(sum(VALUES[:CHAIN + 1]))  # one chain would overflow
    assert math.isfinite(sum(VALUES[:CHAIN]) + sum(VALUES[CHAIN:]))


def test_python_and_compiled_loops_chunk_the_check_alike() -> None:
    rows = {}
    for mode in ("off", "on"):
        store = ResultStore()
        outcome = Execution(many_constants(), [store],
                            algorithm=make_algorithm("gauss_seidel", mode)).run()
        assert outcome.extra.get("algorithm.compiled", False) is (mode == "on"), outcome.extra
        rows[mode] = store.data()
    assert rows["off"].shape == (11, 1 + len(VALUES))
    assert np.array_equal(rows["off"], rows["on"])
    assert np.array_equal(rows["on"][0, 1:], VALUES)
