"""Algebraic loops solved by the master (`experiment.loops: solve`, `twmr.master.loops`): loops
through real FMUs (FMI 2.0 and 3.0, co-simulation and model exchange) and through native blocks
against their analytic fixed points, a loop that does not converge, Newton against fixed point
on a nonlinear loop, refusal as the default, and the statistics of `summary.json`.

The linear loop: c -> s.u1, s = u1 + u2, s.y -> ... -> k (gain) -> s.u2, so s = c + k f(s).
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.fmu_build import build_c_fmu
from twmr.core.errors import AlgebraicLoopError, ScenarioError
from twmr.master import Execution, simulate
from twmr.master.algorithm import admit
from twmr.master.compiled import CompiledStep
from twmr.master.loops import LoopError
from twmr.observers.store import ResultStore
from twmr.scenario import loads
from twmr.scenario.graph import find_loops

NATIVE = """
components:
  c: {kind: constant, parameters: {value: 1.5}}
  s: {kind: sum}
  k: {kind: gain, parameters: {k: %(k)r}}
connections:
  - c.y -> s.u1
  - s.y -> k.u
  - k.y -> s.u2
experiment: {stop: 0.1, step: 0.01%(experiment)s}
record: {signals: [s.y, k.y]}
"""


def native(k: float, experiment: str = ", loops: solve") -> str:
    return NATIVE % {"k": k, "experiment": experiment}


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_c_fmu("mixed2", tmp_path_factory.mktemp("mixed2"))


@pytest.fixture(scope="module")
def types3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_c_fmu("types3", tmp_path_factory.mktemp("types3"), fmi3=True)


def fmu_loop(path: Path, k: float, method: str = "fixed_point", isolate: bool = False) -> str:
    """c = 1 -> s; s -> a.r2; a.r2o = r2 + 1 -> b.r2; b.r2o = r2 + 1 -> k -> s.u2:
    s = 1 + k (s + 2)."""
    return f"""
components:
  c: {{kind: constant, parameters: {{value: 1.0}}}}
  s: {{kind: sum}}
  a: {{kind: fmu, parameters: {{path: {path}, isolate: {str(isolate).lower()}}}}}
  b: {{kind: fmu, parameters: {{path: {path}, isolate: {str(isolate).lower()}}}}}
  k: {{kind: gain, parameters: {{k: {k!r}}}}}
connections:
  - c.y -> s.u1
  - s.y -> a.r2
  - a.r2o -> b.r2
  - b.r2o -> k.u
  - k.y -> s.u2
open: [a.r1, a.i1, a.i2, a.b1, a.s1, b.r1, b.i1, b.i2, b.b1, b.s1]
experiment: {{stop: 0.5, step: 0.1, loops: solve, loop_solver: {{method: {method}}}}}
record: {{signals: [s.y, a.r2o, b.r2o]}}
"""


@pytest.mark.parametrize(("method", "isolate"), [("fixed_point", False), ("newton", False),
                                               ("newton", True)])
def test_loop_through_two_fmus_and_half_gain_converges_to_the_fixed_point(
        mixed: Path, method: str, isolate: bool) -> None:
    """s = 1 + 0.5 (s + 2), so s = 4, a.r2o = 5, b.r2o = 6 at every point (also with each FMU in
    a worker process of its own)."""
    r = simulate(loads(fmu_loop(mixed, 0.5, method, isolate), source="fmu_loop.yaml"))
    assert len(r) == 6
    np.testing.assert_allclose(r["s.y"], 4.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["a.r2o"], 5.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["b.r2o"], 6.0, rtol=0, atol=1e-8)


def test_loop_through_fmi3_fmus_co_simulation_and_model_exchange(types3: Path) -> None:
    """types3's Float64_output = Float64_input, one instance as co-simulation and one as model
    exchange, with a gain of 0.5: s = 2 c. A continuous input of the model exchange FMU
    starts its solver again when it changes, so the loop is found again at every point."""
    text = f"""
components:
  c: {{kind: sine, parameters: {{amplitude: 1.0, frequency: 2.0, offset: 0.5}}}}
  s: {{kind: sum}}
  a: {{kind: fmu, parameters: {{path: {types3}, interface: co_simulation}}}}
  b: {{kind: fmu, parameters: {{path: {types3}, interface: model_exchange}}}}
  k: {{kind: gain, parameters: {{k: 0.5}}}}
connections:
  - c.y -> s.u1
  - s.y -> a.Float64_input
  - a.Float64_output -> b.Float64_input
  - b.Float64_output -> k.u
  - k.y -> s.u2
open: [a.*, b.*]
experiment: {{stop: 1.0, step: 0.05, loops: solve, loop_solver: {{method: newton}}}}
record: {{signals: [c.y, s.y, b.Float64_output]}}
"""
    r = simulate(loads(text, source="fmi3_loop.yaml"))
    assert len(r) == 21 and np.ptp(r["c.y"]) > 1.5
    np.testing.assert_allclose(r["s.y"], 2.0 * r["c.y"], rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["b.Float64_output"], 2.0 * r["c.y"], rtol=0, atol=1e-8)


@pytest.mark.parametrize("solver", ["", ", loop_solver: {method: newton}",
                                    ", loop_solver: {relaxation: 0.7, tol: 1.0e-12}"])
def test_native_loop_of_gain_and_sum_converges(solver: str) -> None:
    """s = 1.5 + 0.5 s: s = 3, k.y = 1.5."""
    r = simulate(loads(native(0.5, ", loops: solve" + solver), source="native.yaml"))
    np.testing.assert_allclose(r["s.y"], 3.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["k.y"], 1.5, rtol=0, atol=1e-8)


def test_gain_two_is_reported_as_not_converging_with_the_results_before_kept(
        tmp_path: Path) -> None:
    """The loop gain is a step from 0.5 to 2 at t = 0.05 s: s = 2 c before, then the fixed-point
    iteration diverges; the run stops at 0.05 s naming the loop, its tear, the residual and the
    time, and the rows before are saved."""
    text = """
components:
  c: {kind: constant, parameters: {value: 1.5}}
  s: {kind: sum}
  gain: {kind: step, parameters: {offset: 0.5, height: 1.5, time: 0.05}}
  p: {kind: product}
  fin: {kind: integrator}
connections:
  - c.y -> s.u1
  - s.y -> p.u1
  - gain.y -> p.u2
  - p.y -> s.u2
  - s.y -> fin.u
experiment: {stop: 0.1, step: 0.01, loops: solve}
record: {signals: [s.y, gain.y]}
"""
    with pytest.raises(LoopError) as info:
        twmr.simulate(twmr.load(text), tmp_path / "run")
    message = str(info.value)
    assert "algebraic loop 1 through s, p (torn at s.u2)" in message
    assert "t = 0.05 s" in message and "after 100 fixed-point iteration(s)" in message
    residual = float(message.split("residual |g(x) - x| is ")[1].split(" ")[0])
    assert residual > 1e20 and info.value.time == pytest.approx(0.05)
    assert "\n" not in message and "Fix:" in message
    saved = twmr.read_result(info.value.partial_results).to_pandas()  # type: ignore[attr-defined]
    assert saved["time"].max() == pytest.approx(0.04) and len(saved) == 5
    np.testing.assert_allclose(saved["s.y"], 3.0, rtol=0, atol=1e-8)


def test_cli_names_the_loop_in_one_paragraph(tmp_path: Path) -> None:
    scenario = tmp_path / "gain2.yaml"
    scenario.write_text(native(2.0))
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(scenario), "-q",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "algebraic loop 1 through s, k" in done.stderr and "t = 0 s" in done.stderr
    assert "loop_solver" in done.stderr and ".incomplete" in done.stderr


TWO_CYCLES = """
components:
  c: {kind: constant, parameters: {value: 1.0}}
  s: {kind: sum, parameters: {signs: "+++"}}
  a: {kind: gain, parameters: {k: 0.25}}
  b: {kind: gain, parameters: {k: -0.5}}
  m: {kind: mux, parameters: {n_in: 2}}
  v: {kind: gain, parameters: {k: 0.5, n_in: 2, n_out: 2}}
  d: {kind: demux, parameters: {n_out: 2}}
connections:
  - c.y -> s.u1
  - s.y -> a.u
  - s.y -> b.u
  - a.y -> m.u1
  - b.y -> m.u2
  - m.y -> v.u
  - v.y -> d.u
  - d.y1 -> s.u2
  - d.y2 -> s.u3
experiment: {stop: 0.02, step: 0.01, loops: solve, loop_solver: {method: %s}}
record: {signals: [s.y]}
"""


@pytest.mark.parametrize("method", ["fixed_point", "newton"])
def test_two_cycles_through_one_vector_input_are_one_loop(method: str) -> None:
    """s = 1 + 0.5 (0.25 s - 0.5 s) through a mux, a vector gain and a demux: one strongly
    connected part, torn at the demux's 2-element input (it lies on both cycles), so Newton
    solves for two unknowns; s = 1 / (1 + 0.125)."""
    system = loads(TWO_CYCLES % method, source="two.yaml")
    loops, stuck = find_loops(system.components, system.connections)
    assert not stuck and [lp.tears for lp in loops] == [(("d", "u"),)]
    r = simulate(system)
    np.testing.assert_allclose(r["s.y"], 1.0 / 1.125, rtol=0, atol=1e-9)


def test_twmr_check_lists_the_loop_and_its_tear(tmp_path: Path) -> None:
    scenario = tmp_path / "loop.yaml"
    scenario.write_text(native(0.5, ", loops: solve, loop_solver: {method: newton}"))
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "check", str(scenario)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "evaluated in this order (`evaluate`): loop 1 (s, k)" in done.stdout
    assert "algebraic loop 1 through s, k: torn at s.u2, solved at each point (newton, tol " \
           "1e-09, max_iter 100, relaxation 1)" in done.stdout


NONLINEAR = """
components:
  c: {kind: constant, parameters: {value: 3.0}}
  s: {kind: sum, parameters: {signs: "+-"}}
  sq: {kind: math, parameters: {function: square}}
connections:
  - c.y -> s.u1
  - s.y -> sq.u
  - sq.y -> s.u2
experiment: {stop: 0.05, step: 0.01, loops: solve, loop_solver: {method: %s}}
record: {signals: [s.y]}
"""


def test_newton_converges_on_a_nonlinear_loop_where_fixed_point_fails() -> None:
    """s = 3 - s^2: the root s = (sqrt(13) - 1) / 2 repels the fixed-point iteration (|g'| =
    2 s > 1) and Newton finds it from s.u2 = 0."""
    r = simulate(loads(NONLINEAR % "newton", source="nonlinear.yaml"))
    np.testing.assert_allclose(r["s.y"], (math.sqrt(13.0) - 1.0) / 2.0, rtol=0, atol=1e-8)
    with pytest.raises(LoopError, match="did not converge at t = 0 s"):
        simulate(loads(NONLINEAR % "fixed_point", source="nonlinear.yaml"))


def test_refusing_stays_the_default_with_the_old_message() -> None:
    for experiment in ("", ", loops: refuse"):
        with pytest.raises(AlgebraicLoopError) as info:
            loads(native(0.5, experiment), source="native.yaml")
        text = str(info.value)
        assert "algebraic loop: s.y -> k.u => k.y -> s.u2 => s.y" in text
        assert "break the loop with a `delay` component" in text and "loops: solve" in text


def test_loop_solver_needs_loops_solve() -> None:
    with pytest.raises(ScenarioError, match="'loop_solver' applies to 'loops: solve' only"):
        loads(native(0.5, ", loop_solver: {method: newton}"), source="native.yaml")
    with pytest.raises(ScenarioError, match="loop_solver/method"):
        loads(native(0.5, ", loops: solve, loop_solver: {method: kinsol}"),
              source="native.yaml")


@pytest.mark.parametrize("experiment", [", algorithm: jacobi", ", loops: solve, algorithm: jacobi"])
def test_jacobi_runs_a_feedthrough_loop_one_step_late(experiment: str,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    """Under Jacobi (libcosim's and Ecos' fixed-step master) every input is the output of the
    point before, so the loop s = 1.5 + k y, y = k s closes a step later: no refusal, nothing
    to solve (said once when 'loops: solve' asks)."""
    with caplog.at_level("WARNING", logger="twmr"):
        r = simulate(loads(native(0.5, experiment), source="native.yaml"))
    assert ("needs no solving" in caplog.text) == ("loops: solve" in experiment)
    s_prev, k_prev, want = 0.0, 0.0, []
    # the outputs after initialize are those of inputs at 0; libcosim's start passes them on
    # once less than there are components (2) before the first point
    for n in range(len(r) + 2):
        s_prev, k_prev = 1.5 + k_prev, 0.5 * s_prev
        if n >= 2:
            want.append((s_prev, k_prev))
    np.testing.assert_allclose(np.column_stack([r["s.y"], r["k.y"]]), want, rtol=0, atol=1e-15)


def test_compiled_loop_refuses_loops_solve_and_auto_keeps_python() -> None:
    system = loads(native(0.5), source="native.yaml")
    with pytest.raises(ScenarioError) as info:
        admit(system, CompiledStep("gauss_seidel", "on"))
    assert "does not run 'loops: solve'" in str(info.value) and "\n" not in str(info.value)
    long = loads(native(0.5).replace("stop: 0.1", "stop: 100.0"), source="native.yaml")
    ex = Execution(long, [store := ResultStore()], algorithm=CompiledStep("gauss_seidel", "auto"))
    ex.run()
    assert ex.outcome.extra["algorithm.compiled"] is False
    assert "algebraic loops" in ex.outcome.extra["algorithm.not_compiled"]
    np.testing.assert_allclose(store.data()[:, 1], 3.0, rtol=0, atol=1e-8)


def test_adaptive_master_solves_the_loop_at_every_point() -> None:
    """u = integral of 1 = t (exact for any step), s = u + 0.5 s = 2 t at every accepted
    point, however long the steps (loose tolerances let them grow). The counts per block are
    the same whether each call is timed (`Options.timing`) or the master's points and steps are
    counted."""
    text = """
components:
  one: {kind: constant, parameters: {value: 1.0}}
  u: {kind: integrator}
  s: {kind: sum}
  k: {kind: gain, parameters: {k: 0.5}}
connections:
  - one.y -> u.u
  - u.y -> s.u1
  - s.y -> k.u
  - k.y -> s.u2
experiment: {stop: 1.0, step: 0.01, algorithm: adaptive, rtol: 0.5, atol: 0.5,
             loops: solve, loop_solver: {method: newton}}
record: {signals: [u.y, s.y]}
"""
    ex = Execution(loads(text, source="adaptive_loop.yaml"), [store := ResultStore()])
    ex.run()
    data = store.data()
    assert data[-1, 0] == pytest.approx(1.0) and len(data) < 101  # the steps grew
    np.testing.assert_allclose(data[:, 1], data[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(data[:, 2], 2.0 * data[:, 0], rtol=0, atol=1e-8)
    stats = ex.outcome.statistics
    rejected = ex.outcome.extra["algorithm.steps_rejected"]
    assert stats["blocks"]["u"]["rejected"] == rejected
    assert stats["loops"]["loop1"]["points"] > len(data)  # the half steps solve it too
    assert stats["blocks"]["u"]["steps"] >= len(data) - 1  # whole and half steps
    assert stats["blocks"]["s"]["evaluations"] == stats["loops"]["loop1"]["evaluations"]
    timed = Execution(loads(text, source="adaptive_loop.yaml"), [ResultStore()],
                      options=twmr.Options(timing=True))
    timed.run()
    blocks = timed.outcome.statistics["blocks"]
    assert all(b.pop("time_s") > 0.0 for b in blocks.values())
    assert blocks == stats["blocks"]


SINE = """
components:
  src: {kind: sine, parameters: {amplitude: 1.0, frequency: 3.0, offset: 1.0}}
  s: {kind: sum, parameters: {signs: "+-"}}
  g: {kind: gain}
connections:
  - src.y -> s.u1
  - s.y -> g.u
  - g.y -> s.u2
experiment: {stop: 0.2, step: 0.01, loops: solve, loop_solver: {relaxation: 0.5}}
"""


@pytest.mark.parametrize("timing", [False, True])
def test_statistics_in_summary_json_are_the_predicted_counts(tmp_path: Path,
                                                             timing: bool) -> None:
    """s = u - s, torn at s.u2 = x: g(x) = u - x, and one fixed-point update with relaxation
    0.5 from any x gives x = u / 2, the solution; so every one of the 21 points (20 steps and
    the final point; the input changes at each) takes one iteration and two passes, each
    evaluating s and g once. Counted while running (`Options.timing`, with the time per block) or
    from the plan, the figures are the same."""
    result = twmr.simulate(twmr.load(SINE), tmp_path / "run",
                           options=twmr.Options(timing=timing))
    summary = json.loads((result.folder / "summary.json").read_text())
    stats = summary["statistics"]
    loop = stats["loops"]["loop1"]
    assert (loop["components"], loop["tears"], loop["method"]) == (["s", "g"], ["s.u2"],
                                                                   "fixed_point")
    assert (loop["points"], loop["iterations"], loop["max_iterations"],
            loop["evaluations"]) == (21, 21, 1, 42)
    blocks = stats["blocks"]
    for name in ("src", "s", "g"):
        assert blocks[name]["steps"] == 20
    assert (blocks["src"]["evaluations"], blocks["s"]["evaluations"],
            blocks["g"]["evaluations"]) == (0, 42, 42)
    assert ("time_s" in blocks["s"]) == timing == ("time_s" in loop)
    np.testing.assert_allclose(result.to_pandas()["s.y"],
                               result.to_pandas()["src.y"] / 2.0, rtol=0, atol=1e-9)


def test_twmr_run_verbose_prints_the_statistics(tmp_path: Path) -> None:
    scenario = tmp_path / "sine.yaml"
    scenario.write_text(SINE)
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(scenario), "-v",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "s: 20 steps, 42 evaluations, " in done.stderr and " ms" in done.stderr
    assert "loop1 (s, g; torn at s.u2; fixed_point): 21 points, 21 iterations (at most 1 " \
           "at one point), 42 passes" in done.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["statistics"]["blocks"]["g"]["time_s"] > 0.0
