"""FMUs inside the compiled loop (`twmr.fmi.compiled_calls`): FMI 2.0 co-simulation FMUs called
through their C function pointers, against the Python loop calling them through fmpy.

The paper's blocks exported as standalone C FMUs (`twmr export`, bit-identical to the Python
blocks) run the paper scenario with every block an FMU, and with a mix of FMUs and native blocks;
the recorded arrays must be equal element for element (`np.array_equal`). A failing FMU
(`tests/fmus/faulty`) stops both loops at the same step with the same rows.
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.fmu_build import build_c_fmu
from tests.integration.c_fmu_scenario import export_blocks, paper, swapped
from twmr.core.errors import CosimError
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import loads


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    return export_blocks(paper(), tmp_path_factory.mktemp("c_fmus"))


def run(text: str, mode: str, algorithm: str = "gauss_seidel") -> tuple[np.ndarray, dict]:
    store = ResultStore()
    ex = Execution(loads(text, source="c_fmu.yaml"), [store],
                   algorithm=make_algorithm(algorithm, mode))
    extra = ex.run().extra
    return store.data(), extra


def scenario(fmus: dict[str, Path], which: list[str], algorithm: str) -> str:
    data = paper()
    data["experiment"].update(stop=3.0, algorithm=algorithm)
    return yaml.safe_dump(swapped(data, {n: fmus[n] for n in which}), sort_keys=False)


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
@pytest.mark.parametrize("which", [["ref", "ctrl", "motor", "plant", "slip"], ["ctrl", "plant"]],
                         ids=["every block an FMU", "two FMUs, three native"])
def test_fmus_in_the_compiled_loop_bit_identical(fmus, which: list[str], algorithm: str) -> None:
    text = scenario(fmus, which, algorithm)
    python, _ = run(text, "off")
    compiled, extra = run(text, "on")
    assert extra["algorithm.compiled"] is True
    assert extra["algorithm.driver"] is True  # FMUs as kinds of the driver, no generated loop
    assert python.shape == (301, 21) and np.array_equal(python, compiled)


def test_auto_keeps_fmus_in_the_python_loop(fmus) -> None:
    """Mode auto leaves an FMU to the Python loop (a hang inside it is named, a crash loses a
    short chunk of rows: tests/hostile/test_fmu_processes.py, test_crash_consistency.py), and
    says why."""
    data = paper()
    data["experiment"]["stop"] = 12.0
    text = yaml.safe_dump(swapped(data, {"ctrl": fmus["ctrl"]}), sort_keys=False)
    _, extra = run(text, "auto")
    assert extra["algorithm.compiled"] is False
    assert "'ctrl' is an FMU, which the compiled loop calls only with --compiled on" in \
        extra["algorithm.not_compiled"]


def test_an_fmu_the_driver_does_not_call_gets_a_loop_of_its_own(tmp_path) -> None:
    """An FMU whose Integer output is recorded: the driver does not carry it, and --compiled on
    compiles a loop for the scenario, with the Python loop's rows."""
    mixed = build_c_fmu("mixed2", tmp_path)
    text = textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          m: {{kind: fmu, parameters: {{path: {mixed}}}}}
        connections: [src.y -> m.r1]
        open: [m.r2, m.i1, m.i2, m.b1, m.s1]
        experiment: {{stop: 0.5, step: 1.0e-3}}
        record: {{signals: [m.r1o, m.i1o]}}
    """)
    python, _ = run(text, "off")
    compiled, extra = run(text, "on")
    assert extra["algorithm.compiled"] is True and extra["algorithm.driver"] is False
    assert np.array_equal(python, compiled)


@pytest.fixture(scope="module")
def faulty(tmp_path_factory) -> Path:
    return build_c_fmu("faulty", tmp_path_factory.mktemp("fmus"))


@pytest.mark.parametrize("mode, words", [(4, "fmi2DoStep"), (6, "asked to terminate")])
def test_a_failing_fmu_stops_both_loops_at_the_same_step(faulty: Path, mode: int,
                                                         words: str) -> None:
    text = textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          dut: {{kind: fmu, parameters: {{path: {faulty}, mode: {mode}, fail_after: 250}}}}
        connections: [src.y -> dut.u]
        experiment: {{stop: 1.0, step: 1.0e-3}}
        record: {{signals: [dut.y, dut.y2, src.y]}}
    """)
    errors, rows = [], []
    for how in ("off", "on"):
        store = ResultStore()
        ex = Execution(loads(text, source="faulty.yaml"), [store],
                       algorithm=make_algorithm("gauss_seidel", how))
        with pytest.raises(CosimError) as info:
            ex.run()
        errors.append(str(info.value))
        rows.append(store.data())
        if how == "on":
            assert ex.algorithm.report()["driver"] is True
    assert all("'dut'" in e and words in e and "t = 0.249" in e for e in errors), errors
    assert rows[0].shape == (250, 4) and np.array_equal(rows[0], rows[1])


@pytest.fixture(scope="module")
def lag2(tmp_path_factory) -> Path:
    return build_c_fmu("lag2", tmp_path_factory.mktemp("lag2"))


def test_many_fmus_are_one_kind_of_the_driver(lag2: Path) -> None:
    """A chain of 40 `lag2` FMUs runs compiled as 40 blocks of one FMU kind of the driver (its
    calls' adapters compiled once, whatever the number of instances), with the Python loop's
    rows."""
    n = 40
    lines = ["components:", "  src: {kind: sine, parameters: {frequency: 2.0}}"]
    lines += [f"  f{i}: {{kind: fmu, parameters: {{path: {lag2}}}}}" for i in range(n)]
    lines += ["connections:", "  - src.y -> f0.u[1]", "  - src.y -> f0.u[2]"]
    lines += [f"  - f{i - 1}.y -> f{i}.u" for i in range(1, n)]
    lines += ["experiment: {stop: 0.5, step: 1.0e-3}",
              f"record: {{signals: [f{n - 1}.y, f{n // 2}.y], decimation: 5}}"]
    text = "\n".join(lines) + "\n"
    python, _ = run(text, "off")
    store = ResultStore()
    algorithm = make_algorithm("gauss_seidel", "on")
    extra = Execution(loads(text, source="chain.yaml"), [store], algorithm=algorithm).run().extra
    assert extra["algorithm.driver"] is True
    assert python.shape == (101, 5) and np.array_equal(python, store.data())
    kinds = {k.key for k in algorithm._kinds_run if k.fmu is not None}
    assert len(kinds) == 1 and sum(k.fmu is not None for k in algorithm._kinds_run) == n
