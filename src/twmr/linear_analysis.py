"""Linear models of any scenario around a point of its run (`twmr linearize`, `twmr.linearize`):
a one-step pulse of height +-amplitude added at each input port at time `at` (a `bias` event, so
FMUs, hardware-free subsystems and compiled loops alike are perturbed as a wire would be), the
outputs' responses over `horizon` steps differenced centrally ((y+ - y-) / 2 amplitude, the
impulse response of the linearisation: its Markov parameters), and a minimal state-space
realisation of them by the eigensystem realisation algorithm (ERA: an SVD of their Hankel
matrix; Juang and Pappa, 1985). The model is discrete at the base step h, as the co-simulation
is (a step is a sample; zero-order hold between them); `continuous()` converts it by the matrix
logarithm where that exists.

Reported with it: the Hankel singular values (the order chosen where they fall below `tol` of
the largest), how well the model reproduces the measured impulse response (relative error),
and how far the response is from linear at that amplitude ((y+ + y- - 2 y0) / (y+ - y-),
relative: 0 for a linear system). Exact for a system that is linear around a steady point;
around a point of a trajectory the model is that of the step map from `at` on, and the
nonlinearity figure says how far to trust it.

`loop_at(port)`: the loop transfer at a wire — the perturbation enters at the input `port`,
the response is read at the output feeding it: T = -L / (1 + L), so L = -T / (1 + T) (negative
feedback convention), whose margins python-control computes.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError, Location

#: default relative Hankel singular value below which a state is dropped
TOL = 1e-7
#: the nonlinearity figure above which a point is refused as a kink (+amplitude and
#: -amplitude answered more than 3 to 1)
KINK = 0.5
#: `at` of the trim point (`steady_time`), and the relative change per step it allows
STEADY = "steady"
STEADY_TOL = 1e-9


@dataclass
class LinearModel:
    """x[k+1] = A x[k] + B u[k], y[k] = C x[k] + D u[k] at step `dt` [s], around time `at`, for
    the input ports `inputs` and output columns `outputs`."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float
    at: float
    inputs: list[str]
    outputs: list[str]
    singular_values: np.ndarray
    fit_error: float
    nonlinearity: float
    markov: np.ndarray  # (horizon + 1) x p x m, the measured impulse response

    @property
    def order(self) -> int:
        return int(self.A.shape[0])

    def ss(self) -> Any:
        """The model as a python-control discrete `StateSpace`."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, self.dt)

    def poles(self) -> np.ndarray:
        """Discrete poles z (eigenvalues of A), and their continuous equivalents log(z) / dt."""
        return np.linalg.eigvals(self.A)

    def analysis(self) -> dict[str, Any]:
        """Transmission zeros z; the ranks of the controllability and observability matrices
        and their conditions (largest / smallest singular value: how near the model is to
        losing a state); for a stable model python-control's `step_info` of each output to a
        unit step at each input ([output][input]; times in s, overshoot in %)."""
        import warnings

        import control

        sys = self.ss()
        out: dict[str, Any] = {"zeros": [[float(z.real), float(z.imag)]
                                         for z in np.sort_complex(sys.zeros())]}
        for name, matrix in (("controllability", control.ctrb(self.A, self.B)),
                             ("observability", control.obsv(self.A, self.C))):
            sv = np.linalg.svd(matrix, compute_uv=False)
            out[name] = {"rank": int(np.linalg.matrix_rank(matrix)), "of": self.order,
                         "condition": float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf}
        if np.all(np.abs(self.poles()) < 1.0):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a pair that does not respond
                info = control.step_info(sys)
            rows = [[info]] if isinstance(info, dict) else info
            out["step"] = [[{k: float(v) for k, v in pair.items()} for pair in row]
                           for row in rows]
        return out

    def continuous(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C, D) of the continuous system whose zero-order-hold discretisation this is
        (`continuous_twin`)."""
        a, b = continuous_twin(self.A, self.B, self.dt, "the discrete model")
        return a, b, self.C, self.D

    def plain(self) -> dict[str, Any]:
        """JSON-ready: the matrices, dt, the point, the ports and the quality figures."""
        return {"A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(),
                "D": self.D.tolist(), "dt": self.dt, "at": self.at, "inputs": self.inputs,
                "outputs": self.outputs, "order": self.order,
                "singular_values": self.singular_values.tolist(), "fit_error": self.fit_error,
                "nonlinearity": self.nonlinearity,
                "poles": [[float(p.real), float(p.imag)] for p in self.poles()],
                **self.analysis()}

    def block_yaml(self, name: str = "lin") -> str:
        """A `state_space` component (continuous, discretised back exactly by the block) that
        plugs into a scenario in place of what was linearised (its outputs as deviations from
        their values at `at`)."""
        import yaml

        a, b, c, d = self.continuous()
        params = {"n_in": len(self.inputs), "n_out": len(self.outputs), "A": a.tolist(),
                  "B": b.tolist(), "C": c.tolist(),
                  "D": float(d[0, 0]) if d.size == 1 else d.tolist()}
        head = (f"# linearised at t = {self.at:g} s: inputs {', '.join(self.inputs)}; outputs "
                f"{', '.join(self.outputs)} (deviations from their values then)\n")
        return head + yaml.safe_dump({name: {"kind": "state_space", "parameters": params}},
                                     sort_keys=False)


def continuous_twin(A: np.ndarray, B: np.ndarray, dt: float, what: str
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the continuous system whose zero-order-hold discretisation at `dt` is the
    discrete (A, B): the matrix logarithm of [[A, B], [0, I]] over dt. CosimError naming
    `what` when A has an eigenvalue on the negative real axis or at 0 (no real logarithm)."""
    from scipy.linalg import logm

    n, m = A.shape[0], B.shape[1]
    z = np.linalg.eigvals(A)
    if np.any((np.abs(z.imag) < 1e-12) & (z.real <= 0)):
        raise CosimError(f"{what} has a pole on the negative real axis or at 0 (a delay, a "
                         f"discrete block, a sampled loop): it has no continuous twin. Fix: "
                         f"use the discrete model (A, B, C, D at dt).")
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:], big[n:, n:] = A, B, np.eye(m)
    log = logm(big) / dt
    if np.abs(log.imag).max(initial=0.0) > 1e-9 * max(1.0, np.abs(log).max()):
        raise CosimError(f"{what}'s matrix logarithm is not real. Fix: use the discrete "
                         f"model.")
    log = log.real
    return log[:n, :n], log[:n, n:]


def linearize(scenario: str | Path | Any, inputs: Sequence[str], outputs: Sequence[str], *,
              at: float | str, horizon: int = 200, amplitude: float = 1e-3,
              order: int | None = None, tol: float = TOL,
              overrides: Sequence[str] = ()) -> LinearModel:
    """The discrete linear model from the input ports `inputs` (scalar ports, each perturbed at
    the wire) to the output ports `outputs` (their elements), around time `at` [s] of a run of
    `scenario` (or `at="steady"`: the trim point its run settles at, `steady_time`), from the
    impulse response over `horizon` steps; order from the Hankel singular values above `tol` of
    the largest, or `order`."""
    from twmr.api import load

    if not inputs or not outputs:
        raise CosimError("linearize needs at least one input and one output port. Fix: give "
                         "--input COMP.PORT and --output COMP.PORT.")
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise CosimError(f"amplitude {amplitude} is not above 0. Fix: give a small positive "
                         f"pulse height in the input's unit.")
    if horizon < 4:
        raise CosimError(f"horizon {horizon} is too short. Fix: give at least 4 steps.")
    base = load(scenario, list(overrides))
    system = base.system
    replayable(system, "linearize")
    h = float(system.experiment.step)
    start = float(system.experiment.start)
    if at == STEADY:
        at = steady_time(base, outputs)
    elif isinstance(at, str):
        raise CosimError(f"at = {at!r} is no point. Fix: give a time of the run [s] or "
                         f"{STEADY!r} (the point the run settles at).")
    k0 = round((at - start) / h) if math.isfinite(at) else -1
    if k0 < 0 or abs(start + k0 * h - at) > 1e-9 * max(1.0, abs(at)):
        raise CosimError(f"at = {at:g} s is not a communication point of the run (start "
                         f"{start:g} s, step {h:g} s). Fix: give start + k step.")
    for port in inputs:
        _scalar_input(port, system)
    t_at = start + k0 * h
    stop = t_at + horizon * h
    plus, minus = [], []
    y0, columns = _pulsed(base.spec, None, t_at, h, stop, outputs)
    for j in range(len(inputs)):
        yp, _ = _pulsed(base.spec, (inputs[j], amplitude), t_at, h, stop, outputs)
        ym, _ = _pulsed(base.spec, (inputs[j], -amplitude), t_at, h, stop, outputs)
        plus.append(yp)
        minus.append(ym)
    # rows from `at` on: Markov parameters M[k] (p x m) = response at at + k h per unit pulse
    markov = np.stack([(yp - ym) / (2 * amplitude) for yp, ym in zip(plus, minus, strict=True)],
                      axis=-1)
    curvature = np.stack([(yp + ym - 2 * y0) for yp, ym in zip(plus, minus, strict=True)],
                         axis=-1)
    spread = np.abs(markov).max() * 2 * amplitude
    nonlinearity = float(np.abs(curvature).max() / spread) if spread > 0 else 0.0
    if nonlinearity > KINK:
        _kinked(markov, curvature, amplitude, inputs, columns, t_at)
    A, B, C, D, sv = era(markov, order, tol)
    fit_error = _fit_error(markov, A, B, C, D)
    return LinearModel(A, B, C, D, h, t_at, list(inputs), columns, sv, fit_error,
                       nonlinearity, markov)


def _kinked(markov: np.ndarray, curvature: np.ndarray, amplitude: float,
            inputs: Sequence[str], columns: Sequence[str], at: float) -> None:
    """CosimError naming the input and output whose responses to +amplitude and -amplitude
    differ most, relative to the response (a kink: no derivative at this point)."""
    per = np.abs(curvature).max(axis=0) / np.maximum(np.abs(markov).max(axis=0) * 2 * amplitude,
                                                     1e-300)
    k, j = (int(i) for i in np.unravel_index(int(np.argmax(per)), per.shape))
    raise CosimError(f"{columns[k]} responds to pulses of +{amplitude:g} and -{amplitude:g} "
                     f"at {inputs[j]} (t = {at:g} s) unequally: y+ + y- - 2 y0 reaches "
                     f"{per[k, j]:.2g} of y+ - y- (0 where the system has a derivative; "
                     f"refused above {KINK:g}): the system has a kink at this point (a "
                     f"saturation's edge, a dead zone, a switch). Fix: linearise at another "
                     f"time (--at), or with a smaller --amplitude if the kink is further than "
                     f"it from the point.")


def steady_time(scenario: Any, outputs: Sequence[str], *, window: int = 50,
                tol: float = STEADY_TOL) -> float:
    """The trim point of a run: the first communication point [s] from which every element of
    `outputs` changes by at most `tol` (relative to max(1, its largest magnitude)) per step for
    `window` steps, in a run of the loaded `scenario` to its stop with its own inputs (set them
    with overrides: the steady state for those inputs). A run that does not settle before its
    stop is refused, naming the output that moves most."""
    system = scenario.system
    h, start = float(system.experiment.step), float(system.experiment.start)
    stop = float(system.experiment.stop)
    y, columns = outputs_run(scenario.spec, None, start, h, stop, outputs)
    change = np.abs(np.diff(y, axis=0)) / np.maximum(1.0, np.abs(y).max(axis=0))
    moving = ~(np.max(change, axis=1) <= tol) if len(change) else np.zeros(0, bool)  # NaN moves
    settled = np.convolve(moving, np.ones(window), "valid") == 0 if len(moving) >= window \
        else np.zeros(0, bool)
    if not settled.any():
        j = int(np.argmax(change[-window:].max(axis=0))) if len(change) else 0
        last = float(change[-window:, j].max()) if len(change) else math.nan
        raise CosimError(
            f"the run does not settle by its stop ({stop:g} s): {columns[j] if columns else '?'}"
            f" still changes by {last:.3g} (relative) per step over its last {window} steps, "
            f"above {tol:g}. Fix: a later experiment.stop (--set experiment.stop=...), inputs "
            f"held at values the system has a steady point for (--set), or a time --at T.")
    return start + int(np.argmax(settled)) * h


def replayable(system: Any, what: str) -> None:
    """CosimError naming the components of `system` that a `what` (which runs the scenario
    again and again from its start, as fast as it can) must not run: hardware in the loop, or
    anything paced to the wall clock."""
    hardware = [n for n, c in system.components.items() if c.needs_realtime]
    if hardware or system.paced:
        who = (f"component{'s' if len(hardware) > 1 else ''} "
               f"{', '.join(repr(n) for n in hardware)} "
               f"{'are' if len(hardware) > 1 else 'is'} hardware in the loop"
               if hardware else "the experiment runs paced to the wall clock (realtime)")
        raise CosimError(f"{what} runs the scenario many times from its start, as fast as it "
                         f"can, but {who}. Fix: {what} the simulated twin (the drives replaced "
                         f"by their model, e.g. kind: motor_driver; realtime: false).")


def era(markov: np.ndarray, order: int | None = None, tol: float = TOL
        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, C, D and the Hankel singular values of a minimal realisation of the Markov
    parameters `markov` ((N + 1) x p x m: D, CB, CAB, ...), by the eigensystem realisation
    algorithm."""
    n_markov, p, m = markov.shape
    r = (n_markov - 2) // 2
    hankel0 = np.block([[markov[1 + i + j] for j in range(r)] for i in range(r)])
    hankel1 = np.block([[markov[2 + i + j] for j in range(r)] for i in range(r)])
    u, s, vt = np.linalg.svd(hankel0)
    if order is None:
        order = int(np.sum(s > tol * s[0])) if s[0] > 0 else 0
    if order < 1:
        raise CosimError("the outputs do not respond to the inputs over the horizon (every "
                         "Hankel singular value is 0). Fix: check that the inputs reach the "
                         "outputs, and give a longer horizon.")
    if order > len(s):
        raise CosimError(f"order {order} is above what the horizon can show ({len(s)}). Fix: "
                         f"give a longer horizon.")
    root = np.sqrt(s[:order])
    un, vn = u[:, :order], vt[:order, :].T
    a = (un / root).T @ hankel1 @ (vn / root)
    b = (root[:, None] * vn.T)[:, :m]
    c = (un * root)[:p, :]
    return a, b, c, markov[0].copy(), s


def _fit_error(markov: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray,
               d: np.ndarray) -> float:
    """|measured - model| / |measured| over the impulse response."""
    model = np.empty_like(markov)
    model[0] = d
    x = b
    for k in range(1, len(markov)):
        model[k] = c @ x
        x = a @ x
    norm = np.linalg.norm(markov)
    return float(np.linalg.norm(markov - model) / norm) if norm > 0 else 0.0


def _scalar_input(port: str, system: Any) -> None:
    """`port` is a scalar port or one element of a port ('comp.port[i]'); else CosimError."""
    from twmr.scenario.graph import element_of

    try:
        comp, name, element = element_of(port, system.components)
    except ValueError as err:
        raise CosimError(f"{err}. Fix: give COMP.PORT or COMP.PORT[i].") from None
    whole = f"{comp}.{name}"
    c = system.components.get(comp)
    if c is None or name not in c.variables:
        from twmr.registry import suggest

        where = list(system.components) if c is None else list(c.inputs) + list(c.outputs)
        raise CosimError(f"'{port}' names no port of the scenario"
                         f"{suggest(comp if c is None else name, where)}. Fix: give COMP.PORT "
                         f"of a wired port.")
    width = c.variables[name].width
    if element > width:
        raise CosimError(f"'{port}': '{whole}' has {width} element(s). Fix: give "
                         f"{whole}[1] to {whole}[{width}].")
    if not element and width != 1:
        raise CosimError(f"'{port}' has {width} elements: an input is perturbed one element "
                         f"at a time. Fix: give {port}[1] (to {port}[{width}]).")


def _pulsed(spec: Any, pulse: tuple[str, float] | None, at: float, h: float, stop: float,
            outputs: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """`outputs_run`, a failure of the run said to be that of linearising (which run, and
    where the point and the horizon take it)."""
    try:
        return outputs_run(spec, pulse, at, h, stop, outputs)
    except CosimError as err:
        which = f"with a pulse of {pulse[1]:+g} at {pulse[0]}" if pulse else "without a pulse"
        raise CosimError(f"linearize: the run {which} at t = {at:g} s, on to {stop:g} s "
                         f"(the horizon), failed: {str(err).partition(' Fix: ')[0]} Fix: "
                         f"linearise at a point the scenario runs through, with a shorter "
                         f"--horizon or a smaller --amplitude.") from None


def outputs_run(spec: Any, pulse: tuple[str, float] | None, at: float, h: float,
                stop: float, outputs: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """The outputs' rows from `at` to `stop` (one per step) of a run of `spec` with a pulse of
    (port, height) over [at, at + h) (None: a pulse of 0, the same blocks)."""
    from twmr.api import load, simulate
    from twmr.scenario.structure import EventSpec, Given, RecordingSpec

    where = Location("<linearize>", 0, "events")
    port, value = pulse if pulse is not None else (None, 0.0)
    events = tuple(spec.events)
    if port is not None:
        events += (EventSpec(Given(at, where), Given(at + h, where), Given(port, where),
                             Given("bias", where), Given(value, where), None, where),)
    ports = dict.fromkeys(o.partition("[")[0] for o in outputs)  # an element: its port's
    record = RecordingSpec(tuple(Given(o, where) for o in ports), Given(1, where), where)
    experiment = dataclasses.replace(spec.experiment, stop=Given(stop, where),
                                     realtime=Given(False, where))
    changed = dataclasses.replace(spec, events=events, record=record, experiment=experiment)
    result = simulate(load(changed), None)
    kept = [j for j, c in enumerate(result.columns)
            if c != "time" and (c in outputs or c.partition("[")[0] in outputs)]
    t = np.asarray(result["time"])
    rows = result.values[t >= at - 1e-9 * h][:, kept]
    return np.asarray(rows, dtype=float), [result.columns[j] for j in kept]


def loop_at(model: LinearModel) -> Any:
    """The loop transfer L = -T / (1 + T) of a model from one input port to the output that
    feeds it (python-control, discrete)."""
    import control

    if len(model.inputs) != 1 or len(model.outputs) != 1:
        raise CosimError("a loop is broken at one wire: one input port and the one output that "
                         "feeds it. Fix: give --loop COMP.PORT alone.")
    return control.feedback(-model.ss(), 1, sign=1)


def source_of(scenario: Any, port: str) -> str:
    """The output that feeds input `port` ('' when none); for an element ('comp.port[i]') the
    element of the output that feeds it."""
    from twmr.scenario.graph import element_of, parse_end

    try:
        comp, name, element = element_of(port, scenario.system.components)
    except ValueError:
        return ""
    for wire in scenario.spec.connections:
        left, _, right = str(wire.value).partition("->")
        try:
            src, dst = parse_end(left), parse_end(right)
        except ValueError:
            continue
        if (dst.comp, dst.port) != (comp, name):
            continue
        if not element:
            return f"{src.comp}.{src.port}"
        into = list(dst.index) if dst.index is not None else None
        if into is not None and element - 1 not in into:
            continue
        k = into.index(element - 1) if into is not None else element - 1
        fed = src.index[k] if src.index is not None else k
        return f"{src.comp}.{src.port}[{fed + 1}]"
    return ""


def bode_figure(model: LinearModel, path: str | Path, loop: Any = None) -> list[Path]:
    """Bode plots (magnitude in dB, phase in degrees, up to the Nyquist frequency) of each
    input-output pair, or of the loop transfer `loop` with its gain and phase margins marked."""
    import control

    from twmr.plots import line_style, pyplot, save

    plt = pyplot()
    nyquist = math.pi / model.dt
    w = np.logspace(math.log10(nyquist) - 4, math.log10(nyquist) * 0.999999, 600)
    fig, (mag_ax, ph_ax) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    pairs = [("L", loop)] if loop is not None else [
        (f"{o} / {i}", model.ss()[k, j]) for j, i in enumerate(model.inputs)
        for k, o in enumerate(model.outputs)]
    for n, (label, sys) in enumerate(pairs):
        response = control.frequency_response(sys, w)
        mag = 20 * np.log10(np.maximum(np.abs(np.ravel(response.magnitude)), 1e-300))
        phase = np.degrees(np.unwrap(np.ravel(response.phase)))
        mag_ax.semilogx(w, mag, label=label, **line_style(n))
        ph_ax.semilogx(w, phase, **line_style(n))
    if loop is not None:
        gm, pm, wcg, wcp = control.margin(loop)
        mag_ax.axhline(0.0, color="#999999", lw=0.6)
        ph_ax.axhline(-180.0, color="#999999", lw=0.6)
        if math.isfinite(wcp):
            ph_ax.axvline(wcp, color="#D55E00", lw=0.8, ls="--")
        if math.isfinite(wcg):
            mag_ax.axvline(wcg, color="#009E73", lw=0.8, ls="--")
        mag_ax.set_title(f"loop at {model.inputs[0]}: gain margin {20 * math.log10(gm):.3g} dB"
                         f" at {wcg:.4g} rad/s, phase margin {pm:.3g} deg at {wcp:.4g} rad/s",
                         fontsize=9, loc="left")
    mag_ax.set_ylabel("magnitude [dB]")
    ph_ax.set_ylabel("phase [deg]")
    ph_ax.set_xlabel(f"frequency [rad/s] (Nyquist {nyquist:.4g} rad/s at step {model.dt:g} s)")
    mag_ax.legend(fontsize=8, frameon=False)
    return save(fig, path)


def read_model(folder: str | Path) -> tuple[LinearModel, str]:
    """The model `twmr linearize` wrote into `folder` (linear.json, linear.npz) and the input
    its loop was broken at ('' when none). CosimError naming what is missing."""
    import json

    where = Path(folder)
    try:
        plain = json.loads((where / "linear.json").read_text())
        with np.load(where / "linear.npz") as saved:
            markov = np.asarray(saved["markov"], dtype=float)
        a, b, c, d = (np.asarray(plain[k], dtype=float).reshape(np.shape(plain[k]) or (0, 0))
                      for k in ("A", "B", "C", "D"))
        model = LinearModel(
            a, b, c, d, float(plain["dt"]), float(plain["at"]), list(plain["inputs"]),
            list(plain["outputs"]), np.asarray(plain["singular_values"], dtype=float),
            float(plain["fit_error"]), float(plain["nonlinearity"]), markov)
        _check_shapes(model)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise CosimError(f"'{where}' holds no model twmr linearize wrote ({err}). Fix: give "
                         f"the folder of `twmr linearize ... --out FOLDER` (linear.json and "
                         f"linear.npz; --fmu models are continuous and not read here).") from None
    return model, model.inputs[0] if "loop" in plain else ""


def _check_shapes(model: LinearModel) -> None:
    """ValueError saying which matrix does not fit the others, the ports or the step."""
    n, m, p = model.A.shape[0], len(model.inputs), len(model.outputs)
    for name, matrix, shape in (("A", model.A, (n, n)), ("B", model.B, (n, m)),
                                ("C", model.C, (p, n)), ("D", model.D, (p, m))):
        if matrix.shape != shape or not np.all(np.isfinite(matrix)):
            raise ValueError(f"{name} is {matrix.shape[0]} x {matrix.shape[1]} (or not "
                             f"finite) where {shape[0]} x {shape[1]} finite numbers belong")
    if not (math.isfinite(model.dt) and model.dt > 0):
        raise ValueError(f"dt = {model.dt} is no step")
    if model.markov.ndim != 3 or model.markov.shape[1:] != (p, m):
        raise ValueError(f"the impulse response in linear.npz is {model.markov.shape}, not "
                         f"(steps, {p}, {m})")


def step_figure(model: LinearModel, path: str | Path) -> list[Path]:
    """The response of each output to a unit step at each input (python-control's
    `step_response` of the discrete model, held between samples), one panel per input."""
    import control

    from twmr.plots import line_style, pyplot, save

    plt = pyplot()
    fig, axes = plt.subplots(len(model.inputs), 1, figsize=(8, 2.2 + 2.2 * len(model.inputs)),
                             squeeze=False)
    response = control.step_response(model.ss())
    t = np.asarray(response.time)
    y = np.asarray(response.outputs).reshape(len(model.outputs), len(model.inputs), len(t))
    for j, (ax, name) in enumerate(zip(axes[:, 0], model.inputs, strict=True)):
        for k, out in enumerate(model.outputs):
            ax.step(t, y[k, j], where="post", label=out, **line_style(k))
        ax.set_title(f"a unit step at {name} (deviations from the point at t = {model.at:g} s)",
                     fontsize=9, loc="left")
        ax.set_ylabel("response")
        ax.legend(fontsize=8, frameon=False)
    axes[-1, 0].set_xlabel("time after the step [s]")
    return save(fig, path)


def nyquist_figure(loop: Any, dt: float, path: str | Path, title: str = "") -> tuple[
        list[Path], np.ndarray]:
    """The Nyquist plot of the discrete loop transfer `loop` (negative feedback convention: the
    critical point -1), from 0 to the Nyquist frequency pi / dt and its mirror image, with -1
    and the unit circle marked; (the files written, the curve's points as complex numbers from
    0 to the Nyquist frequency)."""
    import control

    from twmr.plots import line_style, pyplot, save

    nyquist = math.pi / dt
    w = np.concatenate([[0.0], np.logspace(math.log10(nyquist) - 5, math.log10(nyquist), 2000)])
    points = np.ravel(control.frequency_response(loop, w).complex)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5))
    ax.plot(points.real, points.imag, label="L(e^{jωh}), ω from 0 to π/h", **line_style(0))
    ax.plot(points.real, -points.imag, ls="--", color=line_style(0)["color"], lw=0.8,
            label="its mirror (ω < 0)")
    circle = np.exp(1j * np.linspace(0, 2 * math.pi, 200))
    ax.plot(circle.real, circle.imag, color="#999999", lw=0.6, label="unit circle")
    ax.plot([-1.0], [0.0], "x", color="#D55E00", ms=9, mew=2, label="-1")
    ax.set_xlabel("Re L")
    ax.set_ylabel("Im L")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, frameon=False)
    if title:
        ax.set_title(title, fontsize=9, loc="left")
    return save(fig, path), points


@dataclass
class FmuLinear:
    """x' = A x + B u, y = C x + D u of an FMU at time `at` [s] of a run, from its own
    derivatives (continuous time; states, inputs and outputs by name)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    at: float
    states: list[str]
    inputs: list[str]
    outputs: list[str]
    derivatives: str  # 'directional' or 'adjoint': what the FMU was asked

    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0)

    def plain(self) -> dict[str, Any]:
        return {"A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(),
                "D": self.D.tolist(), "at": self.at, "states": self.states,
                "inputs": self.inputs, "outputs": self.outputs, "continuous": True,
                "derivatives": self.derivatives,
                "poles": [[float(z.real), float(z.imag)] for z in np.sort_complex(self.poles())]}


#: how `linearize_fmu` asks an FMU for its Jacobian
DERIVATIVES = ("auto", "directional", "adjoint")


def linearize_fmu(scenario: str | Path | Any, component: str, *, at: float | str,
                  overrides: Sequence[str] = (), derivatives: str = "auto") -> FmuLinear:
    """The continuous linear model of the FMU `component` (model exchange, or co-simulation at
    a communication point: the Jacobian of the equations it integrates) at time `at` [s] of a
    run of `scenario` (run to `at` step by step, paused there; "steady": the point its outputs
    settle at, `steady_time`), by its directional derivatives, a column per state and input
    (FMI 2 fmi2GetDirectionalDerivative, FMI 3 fmi3GetDirectionalDerivative), or its adjoint
    ones, a row per rate and output (FMI 3 fmi3GetAdjointDerivative; `derivatives="adjoint"`,
    or "auto" when it gives only those): every state, the FMU's real inputs and outputs.
    CosimError when the FMU gives neither."""
    from twmr.api import load
    from twmr.fmi.description import derivatives_provided
    from twmr.fmi.fmu import FmuComponent
    from twmr.stepping import Stepping

    if derivatives not in DERIVATIVES:
        raise CosimError(f"derivatives = {derivatives!r} is none of {', '.join(DERIVATIVES)}. "
                         f"Fix: give one of them.")

    loaded = load(scenario, list(overrides))
    comp = loaded.system.components.get(component)
    if not isinstance(comp, FmuComponent):
        from twmr.registry import suggest

        fmus = [n for n, c in loaded.system.components.items() if isinstance(c, FmuComponent)]
        raise CosimError(f"--fmu {component}: no FMU component of that name run in this "
                         f"process{suggest(component, fmus)} (its FMUs: "
                         f"{', '.join(fmus) or 'none'}). Fix: name a component of kind fmu "
                         f"(without isolate: true).")
    if at == STEADY:
        at = steady_time(loaded, [f"{component}.{name}" for name in comp.outputs])
    elif isinstance(at, str):
        raise CosimError(f"at = {at!r} is no point. Fix: give a time of the run [s] or "
                         f"{STEADY!r} (the point the run settles at).")
    md = comp.md
    interface = "ModelExchange" if comp.me else "CoSimulation"
    directional, adjoint = derivatives_provided(comp.source_path, interface)
    use = derivatives if derivatives != "auto" else "directional" if directional else "adjoint"
    if not (directional if use == "directional" else adjoint):
        what = "directional derivatives" if derivatives == "directional" else \
            "adjoint derivatives" if derivatives == "adjoint" else \
            "directional or adjoint derivatives"
        how = "model exchange" if comp.me else "co-simulation"
        raise CosimError(f"--fmu {component}: '{comp.source_path.name}' cannot be linearised by "
                         f"its derivatives: its {how} interface does not provide {what}. Fix: "
                         f"linearise the scenario from its ports (--input/--output), which needs "
                         f"no derivatives.")
    real = ("Real", "Float64", "Float32")
    rates = [d.variable for d in md.derivatives]  # der(x), the unknowns of A and B
    states = [r.derivative for r in rates]  # x, the knowns of A and C
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type in real]
    outputs = [o.variable for o in md.outputs if o.variable.type in real]
    unknowns = [v.valueReference for v in rates] + [v.valueReference for v in outputs]
    n, p = len(states), len(outputs)
    with Stepping(loaded) as run:
        run.simulate_until(at)
        fmu = comp._fmu  # the run waits between two steps: the FMU is at `at`
        knowns = [v.valueReference for v in (*states, *inputs)]
        if use == "directional":
            J = np.array([fmu.getDirectionalDerivative(unknowns, [k], [1.0]) for k in knowns],
                         dtype=float).reshape(len(knowns), n + p).T
        else:
            J = np.array([fmu.getAdjointDerivative([u], knowns, [1.0], len(knowns))
                          for u in unknowns], dtype=float).reshape(n + p, len(knowns))
        t = run.time
        run.stop()
    for i, out in enumerate(outputs):  # an output that is a state: its row is 1 there, by
        for j, state in enumerate(states):  # definition (some FMUs give rates only)
            if out.valueReference == state.valueReference:
                J[n + i, :] = 0.0
                J[n + i, j] = 1.0
    return FmuLinear(J[:n, :n], J[:n, n:], J[n:, :n], J[n:, n:], t, [v.name for v in states],
                     [v.name for v in inputs], [v.name for v in outputs], use)
