"""The discrete and linear blocks (`transfer_function`, `pid`, `transport_delay`,
`zero_order_hold`, `first_order`, `state_space` with vectors) against references we did not
write: python-control (`c2d`, `forced_response`, frequency response) and scipy.signal
(`cont2discrete`, `dlsim`, `lsim`), numpy.interp, and analytic answers; bad parameters refused by
`twmr check` in one paragraph; each block exported as a C FMU and run in fmpy."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import control
import numpy as np
import pytest
from scipy import signal

from twmr.core.errors import ComponentError, ScenarioError
from twmr.scenario import loads
from twmr.testing import Harness

H = 1e-3
rng = np.random.default_rng(7)


def response(kind: str, params: dict[str, Any], u: np.ndarray, h: float = H) -> np.ndarray:
    """The block's output at t_k = k h for the input samples u[k] (held over each step), as the
    master drives it: write u, evaluate (direct feedthrough), read, step."""
    with Harness(kind, parameters=params, step=h) as dut:
        comp = dut.component
        first = u[0] if np.ndim(u) == 1 else tuple(u[0])
        dut.set(u=first)
        dut.initialize()
        out = []
        for k, uk in enumerate(u):
            dut.set(u=uk if np.ndim(u) == 1 else tuple(uk))
            if comp.has_feedthrough:
                comp.evaluate(k * h)
            out.append(np.ravel(comp.get("y")).copy())
            comp.do_step(k * h, h)
    return np.array(out).squeeze()


def lti_response(sys_d: Any, u: np.ndarray) -> np.ndarray:
    """python-control's response of the discrete system to the samples u (zero initial state)."""
    t = np.arange(len(u)) * sys_d.dt
    return np.ravel(control.forced_response(sys_d, T=t, U=u).outputs)


# -- transfer_function -----------------------------------------------------------------------
TFS = [([1.0], [0.05, 1.0]), ([2.0, 1.0], [1.0, 0.8, 4.0]), ([0.5, 0.0, 1.0], [1.0, 2.0, 3.0]),
       ([3.0, 1.0, 0.5], [1.0, 6.0, 11.0, 6.0])]


@pytest.mark.parametrize("num, den", TFS)
@pytest.mark.parametrize("method", ["zoh", "tustin"])
def test_transfer_function_step_impulse_and_random_input_match_control_c2d(num, den, method):
    # in state space: a third-order polynomial in z with poles near 1 loses digits
    ref = control.c2d(control.tf2ss(num, den), H, method=method)
    n = 2000
    for u in (np.ones(n), np.r_[1.0 / H, np.zeros(n - 1)], rng.standard_normal(n)):
        got = response("transfer_function", {"num": num, "den": den, "method": method}, u)
        want = lti_response(ref, u)
        assert np.allclose(got, want, rtol=1e-9, atol=1e-9 * np.max(np.abs(want))), \
            np.max(np.abs(got - want))


def test_zoh_step_response_is_the_continuous_one_at_the_steps():
    """Zero-order hold is exact for a held input: the samples of the continuous step response
    (scipy.signal.lsim of the continuous system)."""
    num, den = [2.0, 1.0], [1.0, 0.8, 4.0]
    t = np.arange(3000) * H
    _, want, _ = signal.lsim((num, den), np.ones_like(t), t)
    got = response("transfer_function", {"num": num, "den": den}, np.ones_like(t))
    assert np.max(np.abs(got - want)) < 1e-6


def test_discrete_transfer_function_matches_scipy_dlsim():
    num, den = [0.5, -0.2, 0.1], [1.0, -1.2, 0.5]
    u = rng.standard_normal(500)
    _, want = signal.dlsim((num, den, H), u)
    got = response("transfer_function", {"num": num, "den": den, "method": "discrete"}, u)
    assert np.allclose(got, np.ravel(want), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("method", ["zoh", "tustin"])
def test_transfer_function_frequency_response_matches_control(method):
    """A sine through the block, once its transient is gone: amplitude and phase of the
    discrete system's frequency response H(e^{j w h}) (python-control)."""
    num, den, w = [1.0, 3.0], [0.1, 1.0, 4.0], 20.0
    ref = control.c2d(control.tf2ss(num, den), H, method=method)
    g = complex(ref(np.exp(1j * w * H)))
    t = np.arange(8000) * H
    got = response("transfer_function", {"num": num, "den": den, "method": method},
                   np.sin(w * t))
    want = abs(g) * np.sin(w * t + np.angle(g))
    assert np.max(np.abs(got[-2000:] - want[-2000:])) < 1e-9


def test_transfer_function_feedthrough_follows_its_structure():
    def direct(**p: Any) -> bool:
        with Harness("transfer_function", parameters=p) as h:
            return h.component.has_feedthrough
    assert not direct(num=[1.0], den=[1.0, 1.0])
    assert direct(num=[1.0, 0.0], den=[1.0, 1.0])
    assert not direct(num=[0.0, 1.0], den=[1.0, 1.0])  # a leading zero: strictly proper
    assert direct(num=[1.0], den=[1.0, 1.0], method="tustin")


# -- pid -------------------------------------------------------------------------------------
def pid_reference(kp: float, ki: float, kd: float, N: float, h: float) -> Any:
    """C(z) = kp + ki h/(z - 1) + kd N (z - 1)/(z - (1 - N h)): the parallel PID with 1/s by
    forward Euler, h/(z - 1), in the integral and in the derivative filter N/(1 + N/s)."""
    z = control.TransferFunction([1.0, 0.0], [1.0], h)
    return kp + ki * h / (z - 1) + kd * N * (z - 1) / (z - (1 - N * h))


@pytest.mark.parametrize("gains", [(2.0, 0.0, 0.0), (1.0, 5.0, 0.0), (0.5, 2.0, 0.05),
                                   (0.0, 0.0, 0.1)])
def test_pid_step_impulse_and_random_input_match_control(gains):
    kp, ki, kd = gains
    N, n = 200.0, 1500
    ref = pid_reference(kp, ki, kd, N, H)
    for u in (np.ones(n), np.r_[1.0, np.zeros(n - 1)], rng.standard_normal(n)):
        got = response("pid", {"kp": kp, "ki": ki, "kd": kd, "N": N}, u)
        want = lti_response(ref, u)
        assert np.allclose(got, want, rtol=1e-9, atol=1e-9), np.max(np.abs(got - want))


def test_pid_tends_to_the_continuous_pid_as_the_step_shrinks():
    """Step response of kp + ki/s + kd s/(1 + s/N) (control.forced_response of the continuous
    system): the first-order discretisation error falls with h."""
    kp, ki, kd, N = 1.0, 4.0, 0.05, 40.0
    s = control.tf("s")
    cont = kp + ki / s + kd * N * s / (s + N)
    errors = []
    for h in (1e-3, 1e-4):
        t = np.arange(round(0.5 / h)) * h
        want = control.forced_response(cont, T=t, U=np.ones_like(t)).outputs
        got = response("pid", {"kp": kp, "ki": ki, "kd": kd, "N": N}, np.ones_like(t), h)
        errors.append(np.max(np.abs(got[1:] - want[1:])))
    assert errors[1] < errors[0] / 5 and errors[1] < 0.02


def saturated_steps(antiwindup: str) -> int:
    """Steps the output stays at y_max = 1 after the error flips from +1 to -1, with kp = 0,
    ki = 10 1/s, h = 0.01 s (the integral gains 0.1 a step) and 30 steps of +1 before."""
    u = np.r_[np.ones(30), -np.ones(40)]
    y = response("pid", {"kp": 0.0, "ki": 10.0, "limit_output": True, "y_min": -1.0,
                         "y_max": 1.0, "antiwindup": antiwindup, "kb": 100.0}, u, h=0.01)
    assert np.all(y <= 1.0) and np.all(y >= -1.0)
    return int(np.sum(y[30:] >= 1.0 - 1e-12))


def test_pid_anti_windup():
    """Without anti-windup the integral winds up to 3.0 and needs 20 steps back to 1; clamping
    stops it at 1.1 (the step that first exceeds the limit), back-calculation holds it near
    1 + ki e / kb = 1.1: both leave the limit within 2 steps."""
    assert saturated_steps("none") in (20, 21)
    assert saturated_steps("clamping") <= 2
    assert saturated_steps("back_calculation") <= 2


# -- transport_delay, zero_order_hold, first_order -------------------------------------------
def test_transport_delay_of_n_steps_is_the_shifted_signal():
    u = rng.standard_normal(300)
    got = response("transport_delay", {"steps": 7, "y0": 0.25, "buffer": 16}, u)
    assert np.array_equal(got, np.r_[np.full(7, 0.25), u[:-7]])


@pytest.mark.parametrize("delay", [0.0025, 0.004, 0.0131])
def test_transport_delay_interpolates_between_samples_like_numpy_interp(delay):
    t = np.arange(400) * H
    u = np.sin(30.0 * t) + 0.3 * np.cos(70.0 * t)
    got = response("transport_delay", {"delay": delay, "y0": 0.0, "buffer": 32}, u)
    want = np.interp(t - delay, t, u, left=0.0)
    assert np.allclose(got, want, rtol=0, atol=1e-12)


def test_transport_delay_is_element_wise():
    u = rng.standard_normal((50, 3))
    got = response("transport_delay", {"n": 3, "steps": 2, "buffer": 4}, u)
    assert np.array_equal(got[2:], u[:-2]) and np.all(got[:2] == 0.0)


def test_zero_order_hold_samples_at_its_period():
    t = np.arange(200) * H
    u = np.sin(40.0 * t)
    got = response("zero_order_hold", {"sample_period": 0.005}, u)
    want = u[(np.arange(200) // 5) * 5]
    assert np.array_equal(got, want)


def test_first_order_step_response_is_analytic_element_wise():
    t = np.arange(1000) * H
    u = np.tile([1.0, -2.0], (len(t), 1))
    got = response("first_order", {"n": 2, "K": 3.0, "T": 0.1, "y0": 0.5}, u)
    for i, ui in enumerate((1.0, -2.0)):
        want = 3.0 * ui + (0.5 - 3.0 * ui) * np.exp(-t / 0.1)
        assert np.allclose(got[:, i], want, rtol=1e-12, atol=1e-12)


def test_state_space_with_vectors_matches_scipy_dlsim():
    A = [[-1.0, 2.0], [-3.0, -4.0]]
    B = [[1.0, 0.0], [0.5, 2.0]]
    C = [[1.0, -1.0], [0.0, 1.0], [2.0, 0.5]]
    D = [[0.0, 0.1], [0.0, 0.0], [0.3, 0.0]]
    ad, bd, cd, dd, _ = signal.cont2discrete(tuple(map(np.array, (A, B, C, D))), H, method="zoh")
    u = rng.standard_normal((400, 2))
    _, want, _ = signal.dlsim((ad, bd, cd, dd, H), u, x0=np.array([0.5, -1.0]))
    got = response("state_space", {"n_in": 2, "n_out": 3, "A": A, "B": B, "C": C, "D": D,
                                   "x0": [0.5, -1.0]}, u)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-12)


# -- bad input -------------------------------------------------------------------------------
def scenario(kind: str, params: str) -> str:
    return (f"components:\n  blk: {{kind: {kind}, parameters: {{{params}}}}}\n"
            "open: [blk.u]\nexperiment: {stop: 0.01, step: 0.001}\n")


@pytest.mark.parametrize("kind, params, words", [
    ("transfer_function", "num: [1, 2, 3], den: [1, 1]", ["'blk'", "improper", "Fix"]),
    ("transfer_function", "num: [1], den: [0, 1, 1]", ["'blk'", "leading zero", "den"]),
    ("transfer_function", "num: [1], den: [2]", ["'blk'", "degree 0", "gain"]),
    ("transfer_function", "method: euler", ["'blk'", "method", "zoh | tustin | discrete"]),
    ("transport_delay", "delay: -0.1", ["'blk'", "delay", "minimum"]),
    ("transport_delay", "steps: 20, buffer: 8", ["'blk'", "steps", "buffer >= 21"]),
    ("pid", "limit_output: true, y_min: 2, y_max: 1", ["'blk'", "y_min", "above", "y_max"]),
    ("pid", "antiwindup: clamp", ["'blk'", "antiwindup", "back_calculation"]),
    ("first_order", "T: 0", ["'blk'", "T", "positive"]),
    ("zero_order_hold", "sample_period: 0", ["'blk'", "sample_period", "positive"]),
    ("state_space", "n_in: 2, A: [-1], B: [1], C: [1]", ["'blk'", "B has 1 values", "n_in"]),
])
def test_bad_parameters_are_refused_at_check_in_one_paragraph(kind, params, words):
    with pytest.raises(ScenarioError) as err:
        loads(scenario(kind, params))
    text = str(err.value)
    assert "Traceback" not in text and "\n\n" not in text.strip()
    for word in words:
        assert word in text, text


@pytest.mark.parametrize("kind, params, words", [
    ("zero_order_hold", {"sample_period": 0.0025}, ["sample_period", "whole number", "Fix"]),
    ("transport_delay", {"delay": 0.1, "buffer": 16}, ["delay", "buffer >= 101"]),
    ("pid", {"kd": 0.1, "N": 5000.0}, ["N", "unstable", "Fix"]),
])
def test_step_dependent_parameters_are_refused_before_the_run(kind, params, words):
    with pytest.raises(ComponentError) as err, Harness(kind, parameters=params, step=H) as dut:
        dut.initialize()
    for word in ("'dut'", *words):
        assert word in str(err.value), err.value


# -- export and fmpy -------------------------------------------------------------------------
KINDS = {"transfer_function": ["num=[1.0]", "den=[0.1, 1.0]"],
         "pid": ["kp=2.0", "ki=1.0", "limit_output=true", "antiwindup=clamping"],
         "transport_delay": ["steps=3", "buffer=8"], "zero_order_hold": ["sample_period=0.002"],
         "first_order": ["T=0.01", "n=2"], "state_space": ["n_in=2", "B=[[1.0, 1.0]]", "D=[0, 0]"]}


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_twmr_export_runs_in_fmpy(kind, tmp_path: Path):
    from fmpy import read_model_description, simulate_fmu

    out = tmp_path / f"{kind}.fmu"
    sets = [a for s in KINDS[kind] for a in ("--set", s)]
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "export", kind, "--out", str(out),
                           *sets], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    md = read_model_description(str(out))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    signal_in = np.array([(t, *([1.0] * len(inputs))) for t in (0.0, 1.0)],
                         dtype=[("time", float)] + [(n, float) for n in inputs])
    res = simulate_fmu(str(out), stop_time=0.05, output_interval=H, input=signal_in,
                       fmi_type="CoSimulation")
    names = [v.name for v in md.modelVariables if v.causality == "output"]
    u = np.ones((len(res), len(inputs)))
    params = {s.split("=")[0]: _value(s.split("=")[1]) for s in KINDS[kind]}
    want = response(kind, params, u.squeeze() if len(inputs) == 1 else u)
    got = np.column_stack([res[n] for n in names]).squeeze()
    assert np.allclose(got, want.reshape(got.shape), rtol=1e-10, atol=1e-12)


def _value(text: str) -> Any:
    import yaml

    return yaml.safe_load(text)



def test_tustin_has_no_c_twin_and_says_what_to_do(tmp_path: Path):
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "export", "transfer_function",
                           "--set", "method=tustin", "--out", str(tmp_path / "t.fmu")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "method 'tustin' has no C kernel" in done.stderr and "--python" in done.stderr


@pytest.mark.parametrize("block, message", [
    ("{kind: zero_order_hold, parameters: {sample_period: 0.0015}}",
     "(components.z.parameters.sample_period): component 'z' (zero_order_hold): sample_period "
     "= 0.0015 s is not a whole number of steps of 0.001 s. Fix: give a multiple of the step."),
    ("{kind: pid, parameters: {kp: 1, kd: 1, N: 5000}}",
     "(components.z.parameters.N): component 'z' (pid): N = 5000.0 1/s makes the derivative "
     "filter unstable at steps of 0.001 s"),
    ("{kind: transport_delay, parameters: {delay: 1.0, buffer: 10}}",
     "(components.z.parameters.delay): component 'z' (transport_delay): delay = 1.0 s is 1000 "
     "steps of 0.001 s, more than a buffer of 10 samples holds. Fix: give buffer >= 1001."),
])
def test_what_depends_on_the_step_is_refused_at_check_at_its_line(block: str, message: str
                                                                   ) -> None:
    from twmr.core import ScenarioError
    from twmr.scenario import loads

    with pytest.raises(ScenarioError) as err:
        loads(f"components:\n  z: {block}\nopen: ['z.*']\nexperiment: {{stop: 0.01, "
              f"step: 0.001}}\n", source="s.yaml")
    assert str(err.value).startswith(f"s.yaml:2 {message}"), str(err.value)
