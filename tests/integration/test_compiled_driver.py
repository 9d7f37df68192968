"""The compiled driver (`twmr.master.driver`): one numba driver per set of block kinds, so a
rewired scenario, or a longer chain of the same kinds, runs compiled without compiling anything,
and its rows are the Python schedule's bit for bit.

Compilations are counted with numba's own event stream (`numba.core.event`, kind
'numba:compile': one event per function numba compiles, or loads from its cache, for a
signature)."""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
from numba.core import event

from tests.integration.test_compiled import ROOT, rewired, run
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.master.compiled import AUTO_MIN_STEPS, CompiledStep
from twmr.observers.store import ResultStore
from twmr.scenario import load

PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"


def chain(n: int, stop: float = 0.5, algorithm: str = "gauss_seidel") -> str:
    """A sine through `n` gain blocks in a row (gains alternating around 1), the last recorded."""
    lines = ["components:",
             "  src: {kind: sine, parameters: {amplitude: 1.0, frequency: 2.0}}"]
    lines += [f"  g{i}: {{kind: gain, parameters: {{k: {1.001 if i % 2 else 0.9995}}}}}"
              for i in range(n)]
    lines += ["connections:", "  - src.y -> g0.u"]
    lines += [f"  - g{i - 1}.y -> g{i}.u" for i in range(1, n)]
    lines += [f"experiment: {{start: 0.0, stop: {stop}, step: 0.001, algorithm: {algorithm}}}",
              f"record: {{signals: [src.y, g0.y, g{n - 1}.y]}}"]
    return "\n".join(lines) + "\n"


def counted(system, mode: str = "on") -> tuple[np.ndarray, dict, int]:
    """(rows, outcome extra, numba compilations during the run) of `system`."""
    with event.install_recorder("numba:compile") as rec:
        rows, extra = run(system, mode)
    return rows, extra, len([e for e in rec.buffer if e[1].is_start])


def test_a_rewired_scenario_runs_compiled_without_a_compile() -> None:
    base, extra, _ = counted(load(PAPER, ["experiment.stop=1.0"]))
    assert extra["algorithm.driver"] is True
    for algorithm in ("gauss_seidel", "jacobi"):
        python, _ = run(rewired(algorithm), "off")
        compiled, extra, compiles = counted(rewired(algorithm))
        assert compiles == 0, extra
        assert extra["algorithm.compiled"] is True and extra["algorithm.driver_compiled"] is False
        assert np.array_equal(python, compiled)
        assert not np.array_equal(base, compiled[:len(base)])  # the rewiring matters


def test_fewer_kinds_and_other_multiples_reuse_the_driver() -> None:
    """The SMC scenario (a subset of the ASMC scenario's kinds but the controller) and step
    multiples: no compile once a driver holds the kinds."""
    run(load(ROOT / "scenarios" / "paper_trajectory1_smc.yaml", ["experiment.stop=0.2"]), "on")
    run(load(PAPER, ["experiment.stop=0.2"]), "on")
    for path, extra_overrides in ((PAPER, ["ctrl.step_multiple=5", "motor.step_multiple=2"]),
                                  (ROOT / "scenarios" / "paper_trajectory1_asmc_noslip.yaml",
                                   [])):
        overrides = ["experiment.stop=2.0", *extra_overrides]
        python, _ = run(load(path, overrides), "off")
        compiled, extra, compiles = counted(load(path, overrides))
        assert compiles == 0 and extra["algorithm.driver_compiled"] is False
        assert np.array_equal(python, compiled)


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
def test_a_chain_of_1000_gains_runs_compiled_bit_identical(tmp_path: Path,
                                                           algorithm: str) -> None:
    short = tmp_path / "chain10.yaml"
    short.write_text(chain(10, algorithm=algorithm))
    run(load(short), "on")  # the driver of {sine, gain}
    path = tmp_path / "chain1000.yaml"
    path.write_text(chain(1000, stop=1.2, algorithm=algorithm))
    python, _ = run(load(path), "off")
    compiled, extra, compiles = counted(load(path))
    assert extra["algorithm.compiled"] is True and compiles == 0
    assert np.array_equal(python, compiled)
    assert python.shape == (1201, 4) and abs(compiled[-1, 3]) > 0.1
    if algorithm == "jacobi":  # one step late per gain: 1000 steps to the end of the chain
        assert not compiled[:1000, 3].any() and compiled[-1, 3] != 0.0


def test_auto_compiles_a_short_run_once_its_kinds_are_compiled() -> None:
    run(load(PAPER, ["experiment.stop=0.2"]), "on")
    system = load(PAPER, ["experiment.stop=1.0", "ctrl.k=20"])
    algo = make_algorithm("gauss_seidel", "auto")
    assert isinstance(algo, CompiledStep)
    store = ResultStore()
    Execution(system, [store], algorithm=algo).run()
    assert algo.compiled is True and algo.driver_compiled is False
    python, _ = run(load(PAPER, ["experiment.stop=1.0", "ctrl.k=20"]), "off")
    assert np.array_equal(python, store.data())


def test_auto_finds_the_driver_in_numba_cache_in_a_new_process(tmp_path: Path) -> None:
    """`twmr run --compiled auto` in fresh processes: a short run in Python while the cache
    folder is empty and still once a run has filled it (loading numba costs it more than its
    steps), a run of `AUTO_MIN_STEPS` compiled from the cache."""
    import twmr
    from tests.hostile.runner import assert_ok, run_cli

    (tmp_path / "c.yaml").write_text(chain(3, stop=0.2))
    (tmp_path / "long.yaml").write_text(chain(3, stop=AUTO_MIN_STEPS * 0.001))
    env = {**os.environ, "TWMR_CACHE_DIR": str(tmp_path / "cache")}
    pacing = []
    for mode, name, out in (("auto", "c", "first"), ("on", "c", "fill"), ("auto", "c", "again"),
                            ("auto", "long", "long")):
        o = run_cli(["run", f"{name}.yaml", "--compiled", mode, "--out", out], tmp_path,
                    timeout=600, env=env)
        assert_ok(o)
        pacing.append(twmr.read_result(tmp_path / out).summary["pacing"])
    assert [p["algorithm.compiled"] for p in pacing] == [False, True, False, True]
    assert "not held by this process" in pacing[2]["algorithm.not_compiled"]


def test_a_block_whose_parameters_the_driver_cannot_hold_runs_the_generated_loop() -> None:
    """A kernel with a parameter of a type the float vectors do not hold (a complex number)
    is compiled the old way: one loop for the scenario, bit-identical as well."""
    from tests.helpers import system
    from tests.integration.test_compiled import LowPass
    from twmr.blocks import Sine

    class Odd(LowPass):
        def kernel(self, h: float):  # a complex parameter the kernel does not read
            k = super().kernel(h)
            return dataclasses.replace(k, params=(*k.params, 1j))

    def build():
        return system([Sine("s", frequency=3.0), Odd("f", tau=0.05)], ["s.y -> f.u"], 0.5,
                      1e-3, record=["f.y"])

    python, _ = run(build(), "off")
    compiled, extra = run(build(), "on")
    assert extra["algorithm.compiled"] is True and extra["algorithm.driver"] is False
    assert np.array_equal(python, compiled)


@pytest.mark.parametrize("joined", [True, False])
def test_a_runs_chunks_are_recorded_into_one_buffer_the_result_shares(
        monkeypatch: pytest.MonkeyPatch, joined: bool) -> None:
    """The compiled chunks write consecutive rows of one buffer, which the in-memory store hands
    out without a copy; above `JOINED` values each chunk has its own and they are joined by a
    copy: the same rows as the Python schedule either way."""
    from twmr.master import compiled

    if not joined:
        monkeypatch.setattr(compiled, "JOINED", 100)
    overrides = ["experiment.stop=2.0"]  # (recorded every 10th step)
    python, _ = run(load(PAPER, overrides), "off")
    store = ResultStore()
    Execution(load(PAPER, overrides), [store], algorithm=make_algorithm("gauss_seidel", "on")
              ).run()
    assert len(store.blocks) >= 3 and np.array_equal(store.data(), python)
    bases = {id(b.base) for b in store.blocks}
    assert (len(bases) == 1 and store.data().base is store.blocks[0].base) is joined
