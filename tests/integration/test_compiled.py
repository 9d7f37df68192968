"""The compiled fixed-step algorithm (`twmr.master.compiled`) against the Python schedule.

Every run here is made twice, with `compiled='off'` (the generated Python loop) and compiled
('on': from the first step; 'auto': after the first Python chunk), and the recorded arrays must be
equal element for element (`np.array_equal`, no tolerance): the compiled loop evaluates the same
expressions in the same order. The paper scenarios are cut to a few seconds (the first seconds
hold the transient, the saturation and the adaptation); one runs its full length.
"""
from __future__ import annotations

import dataclasses
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from twmr.core import Component, Input, Output, Parameter
from twmr.core.errors import ComponentError
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.master.compiled import CompiledStep, CompileError, Kernel
from twmr.observers.store import ResultStore
from twmr.scenario import load

ROOT = Path(__file__).resolve().parents[2]
PAPER = sorted((ROOT / "scenarios").glob("paper_*.yaml"))


def run(system, mode: str) -> tuple[np.ndarray, dict]:
    """The recorded rows and the outcome's extra figures of one run of `system`."""
    store = ResultStore()
    algo = make_algorithm(system.experiment.algorithm, mode)
    outcome = Execution(system, [store], algorithm=algo).run()
    return store.data(), outcome.extra


def same(path: Path | str, overrides: list[str], mode: str = "on") -> np.ndarray:
    """Run the scenario Python and compiled; assert bit-identity and that it did compile."""
    python, _ = run(load(path, overrides), "off")
    compiled, extra = run(load(path, overrides), mode)
    assert extra["algorithm.compiled"] is True, extra
    assert extra["algorithm.driver"] is True, extra  # the driver of the kinds, not a loop
    assert python.shape == compiled.shape
    assert np.array_equal(python, compiled), np.max(np.abs(python - compiled))
    return compiled


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
@pytest.mark.parametrize("path", PAPER, ids=[p.stem for p in PAPER])
def test_paper_scenario_compiled_is_bit_identical(path: Path, algorithm: str) -> None:
    same(path, [f"experiment.algorithm={algorithm}", "experiment.stop=4.0"])


def test_full_paper_run_auto_switches_after_the_first_chunk_bit_identical() -> None:
    rows = same(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", [], mode="auto")
    assert rows.shape == (3001, 21)


VARIANTS = {
    "dc_motor": ["motor.mode=dc"],
    "scale_saturation_no_hold": ["ctrl.saturation=scale", "ctrl.hold_saturated=false",
                                 "ctrl.d_hat_limit=2.0", "ctrl.drive=auto"],
    "circle_forward_sgn": ["ref.shape=circle", "ctrl.drive=forward", "ctrl.phi=0.0"],
    "lemniscate": ["ref.shape=lemniscate", "ref.radius=3.0"],
    "slip_step": ["slip.profile=step", "slip.step_time=1.5", "slip.slip_gain=0.5"],
    "slip_mud": ["slip.profile=mud", "slip.mud_center=[0.0, 1.0]", "slip.mud_radius=1.0"],
    "slip_constant": ["slip.profile=constant"],
    "multirate": ["ctrl.step_multiple=5", "motor.step_multiple=5"],
}


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
@pytest.mark.parametrize("name", list(VARIANTS))
def test_paper_block_variants_bit_identical(name: str, algorithm: str) -> None:
    same(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
         [*VARIANTS[name], f"experiment.algorithm={algorithm}", "experiment.stop=3.0"])


LINEAR = """
components:
  ref: {kind: step, parameters: {height: 1.0, time: 0.1}}
  wave: {kind: sine, parameters: {amplitude: 0.5, frequency: 2.0, phase: 0.3, offset: 0.1}}
  c: {kind: constant, parameters: {value: 0.25}}
  err: {kind: sum, parameters: {k2: -1.0}}
  dist: {kind: sum, parameters: {k1: 1.0, k2: 1.0}}
  ctrl: {kind: gain, parameters: {k: 2.0}}
  plant: {kind: integrator, parameters: {k: 1.5}}
  lag: {kind: delay}
connections:
  - ref.y -> err.u1
  - lag.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> dist.u1
  - wave.y -> dist.u2
  - dist.y -> plant.u
  - plant.y -> lag.u
experiment: {start: 0.5, stop: 3.0, step: 0.01, algorithm: %s}
record: {signals: [plant.y, ctrl.y, dist.y, lag.y, c.y, err.u1], decimation: 2}
"""


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
def test_linear_blocks_compiled_bit_identical(tmp_path: Path, algorithm: str) -> None:
    path = tmp_path / "linear.yaml"
    path.write_text(LINEAR % algorithm)
    same(path, [])
    same(path, ["plant.step_multiple=4", "lag.step_multiple=2"])


def rewired(algorithm: str):
    """The paper scenario with a unit gain and offset on the reference position and the wheel
    speed to the motor wired element by element (as a unit conversion and `[i]` wires make
    them)."""
    system = load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                  [f"experiment.algorithm={algorithm}", "experiment.stop=2.0"])
    conns = []
    for c in system.connections:
        if (c.dst, c.dst_port) == ("ctrl", "ref_position"):
            conns.append(dataclasses.replace(c, gain=1.0001, offset=0.01))
        elif (c.dst, c.dst_port) == ("motor", "wheel_speed"):
            conns += [dataclasses.replace(c, src_index=(1,), dst_index=(0,), gain=0.5),
                      dataclasses.replace(c, src_index=(0,), dst_index=(1,))]
        else:
            conns.append(c)
    system.connections = conns
    return system


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
def test_unit_conversion_and_element_wiring_bit_identical(algorithm: str) -> None:
    python, _ = run(rewired(algorithm), "off")
    compiled, extra = run(rewired(algorithm), "on")
    assert extra["algorithm.compiled"] is True
    assert np.array_equal(python, compiled)
    plain, _ = run(load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                        [f"experiment.algorithm={algorithm}", "experiment.stop=2.0"]), "on")
    assert not np.array_equal(plain, compiled)  # the rewiring matters


def test_inf_stops_at_the_same_time_naming_the_same_port(tmp_path: Path) -> None:
    """An Inf in a wired output: the same ComponentError text and the same rows up to it."""
    path = tmp_path / "linear.yaml"
    path.write_text(LINEAR % "gauss_seidel")
    overrides = ["ref.height=1e300", "ctrl.k=1e10", "ref.time=1.25"]
    errors, rows = [], []
    for mode in ("off", "on"):
        store = ResultStore()
        ex = Execution(load(path, overrides), [store],
                       algorithm=make_algorithm("gauss_seidel", mode))
        with pytest.raises(ComponentError) as info:
            ex.run()
        errors.append(str(info.value))
        rows.append(store.data())
    assert "'ctrl'" in errors[0] and "'y'" in errors[0] and "t = 1.25" in errors[0]
    assert errors[0] == errors[1]
    assert rows[0].shape[0] > 10 and np.array_equal(rows[0], rows[1])


def test_mode_on_without_a_kernel_is_a_one_paragraph_error() -> None:
    system = load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                  ["slip.profile=random", "experiment.stop=0.1"])
    with pytest.raises(CompileError) as info:
        Execution(system, [ResultStore()], algorithm=make_algorithm("gauss_seidel", "on")).run()
    text = str(info.value)
    assert "'slip'" in text and "no compiled kernel" in text and "Fix:" in text
    assert "\n" not in text


def test_auto_falls_back_to_python_for_a_block_without_kernel() -> None:
    system = load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                  ["slip.profile=random", "experiment.stop=12.0"])
    algo = make_algorithm("gauss_seidel", "auto")
    assert isinstance(algo, CompiledStep)
    Execution(system, [ResultStore()], algorithm=algo).run()
    assert algo.compiled is False and "'slip'" in algo.reason


def test_a_subclass_overriding_evaluate_runs_in_python() -> None:
    from twmr.blocks import Gain

    class Twice(Gain):
        def evaluate(self, t: float) -> None:
            self.y = 2.0 * self.k * self.u

    from tests.helpers import system
    from twmr.blocks import Sine

    sysm = system([Sine("s"), Twice("g", k=1.0)], ["s.y -> g.u"], 0.1, 0.01, record=["g.y"])
    store = ResultStore()
    with pytest.raises(CompileError, match="overrides the methods"):
        Execution(sysm, [store], algorithm=make_algorithm("gauss_seidel", "on")).run()


def test_implausible_motor_command_is_warned_about_once_when_compiled(caplog) -> None:
    overrides = ["ctrl.torque_limit=0.0", "motor.torque_max=1.0", "experiment.stop=2.0"]
    counts = []
    for mode in ("off", "on"):
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="twmr.run"):
            run(load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", overrides), mode)
        counts.append([r.getMessage() for r in caplog.records if "far beyond" in r.getMessage()])
    assert len(counts[0]) == 1 and counts[0] == counts[1]


STATE_SPACE = """
components:
  ref: {kind: step, parameters: {height: 1.0, time: 0.0}}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl: {kind: gain, parameters: {k: 5.0}}
  plant:
    kind: state_space
    parameters: {A: %s, B: %s, C: %s, D: 0.0}
connections:
  - ref.y -> err.u1
  - plant.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment: {start: 0.0, stop: 5.0, step: 1.0e-3, algorithm: %s}
record: {signals: [plant.y, ctrl.y]}
"""


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
@pytest.mark.parametrize("matrices", [
    ("[[0.0, 1.0], [-2.0, -3.0]]", "[0.0, 1.0]", "[1.0, 0.0]"),
    ("[[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-6.0, -11.0, -6.0]]", "[0.0, 0.3, 1.0]",
     "[1.0, 0.7, 0.2]")], ids=["2 states", "3 states"])
def test_state_space_loop_bit_identical(tmp_path: Path, matrices: tuple, algorithm: str) -> None:
    path = tmp_path / "ss.yaml"
    path.write_text(STATE_SPACE % (*matrices, algorithm))
    same(path, [])


@njit(cache=True)
def lowpass_step(t, h, x, y, u, p):
    """docs/components.md's example: y(t + h) = a y + (1 - a) u; p = (a,)."""
    a = p[0]
    return x, (a * y[0] + (1.0 - a) * u[0],)


class LowPass(Component):
    """docs/components.md's example block."""

    kind = "lowpass_doc_example"
    tau = Parameter(0.1, unit="s", min=1e-9, description="time constant")
    u = Input(0.0)
    y = Output(0.0)

    def do_step(self, t: float, h: float) -> None:
        a = math.exp(-h / self.tau)
        self.y = a * self.y + (1.0 - a) * self.u

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=(math.exp(-h / self.tau),), step=lowpass_step)


def test_the_documented_example_block_compiles_bit_identical() -> None:
    from tests.helpers import system
    from twmr.blocks import Sine

    def build():
        return system([Sine("s", frequency=3.0), LowPass("f", tau=0.05)], ["s.y -> f.u"], 2.0,
                      1e-3, record=["f.y"], multiples={"f": 2})

    python, _ = run(build(), "off")
    compiled, extra = run(build(), "on")
    assert extra["algorithm.compiled"] is True
    assert np.array_equal(python, compiled) and abs(compiled[-1, 1]) > 0.01


def test_auto_leaves_a_short_run_to_python_while_its_kinds_have_no_driver(
        tmp_path: Path, monkeypatch) -> None:
    from twmr.master import driver

    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "empty"))
    monkeypatch.setattr(driver, "_LOADED", [])  # as a new process
    system = load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", ["experiment.stop=1.0"])
    algo = make_algorithm("gauss_seidel", "auto")
    Execution(system, [ResultStore()], algorithm=algo).run()
    assert algo.compiled is False and "short run" in algo.reason


def test_an_unwritable_cache_folder_still_compiles(tmp_path: Path, monkeypatch) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("TWMR_CACHE_DIR", str(blocker / "cache"))  # below a file: mkdir fails
    same(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", ["experiment.stop=0.5"])
