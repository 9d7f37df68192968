"""Every registered block's three forms are one definition: for each kind with a C twin (its
class's `c_twin`) and each kind of `twmr.components` that offers a compiled kernel,
hypothesis draws the variant (each compiled-in choice the twin supports, the order of a
variable-size block, the size of an element-wise one), the Real parameters within their declared
min/max, the initial states, the start time, the step size and a sequence of inputs, and drives

- the Python form: the component's own methods (`initialize`, `evaluate`, `do_step`), as the
  master's Gauss-Seidel loop calls them for one block;
- the compiled form: its kernel functions (`Component.kernel(h)`), called the way the generated
  loop calls them;
- the C form: the block's standalone C FMU (`twmr.fmi.cexport.export_c_fmu`, exported once per
  variant per session) through fmpy, its parameters and initial states set through FMI: FMI 2.0
  for every example, and the same twin exported as FMI 3.0 for the first `EXAMPLES_FMI3` (the
  two wrappers share the twin and the instance code; FMI 3.0 checks its own calls).

Python and compiled must agree bit for bit at every communication point. C must agree within

    |C - Python| <= REL * max(1, max |Python| over the run)     for each output element

REL = 1e-12, the bound of the whole-scenario tests (tests/integration/test_c_export_scenarios.py).
Why not 0: the twins do the same IEEE operations in the same order (compiled with
-ffp-contract=off), so most kinds agree bit for bit, but some discretisations are computed
differently on purpose: `state_space` and `transfer_function` with zoh (scipy's Pade `expm` in
Python, a Taylor series with scaling and squaring in C, c/expm.h) and the `dc` motor
(python-control's `c2d` against the closed form a = exp(-R h / L)); they differ in the last place
of the discrete matrices, which the steps carry into the outputs. Measured over this test's
examples (the worst err / scale per kind): motor_driver 7.9e-16, transfer_function 3.4e-16,
state_space 2.6e-16 of the scale, every other kind 0. A changed operator,
constant or index in a twin gives errors of the order of the signal itself, far above REL.

A kind added to either registry is covered by this test with no edit of it. A block whose
parameters constrain each other (sorted breakpoints, a sample period that is a multiple of the
step) offers a classmethod `example(params, h) -> params` that makes drawn parameters valid; one
whose parameters cannot be drawn at all (coefficient lists, sizes that constrain each other, a
sign pattern) offers `examples(h)`, parameter sets for steps of h, one of which is drawn.
"""
from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twmr.core.port import BOOLEAN, REAL
from twmr.fmi.cexport import export_c_fmu, twin_of, twins
from twmr.fmi.cexport.describe import elements
from twmr.registry import kinds, lookup
from twmr.testing import Harness

REL = 1e-12
EXAMPLES = 12
#: the sizes drawn for an element-wise block (`Component.sized_by`) whose twin names no orders
SIZES = (1, 3)
EXAMPLES_FMI3 = 3
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
SETTINGS_FMI3 = settings(SETTINGS, max_examples=EXAMPLES_FMI3)


def _offers_kernel(kind: str) -> bool:
    try:
        cls = lookup(kind)
    except ImportError:  # a plug-in whose optional dependencies are not installed
        return False
    return callable(getattr(cls, "kernel", None))


KINDS = sorted(set(twins()) | {k for k in kinds() if _offers_kernel(k)})


# -- what is drawn ---------------------------------------------------------------------------
def _element(var: Any, default: float) -> st.SearchStrategy[float]:
    """A value for one element of parameter `var`: its default, or uniform in [d/4, 4d] for a
    positive default under a lower bound (masses, lengths, steps), else in d +- (4|d| + 1);
    clipped to the declared min/max; a default that is no finite number (a stop time of inf) as
    it is."""
    if not math.isfinite(default):
        return st.just(float(default))
    if var.min is not None and default > 0.0:
        lo, hi = default / 4.0, default * 4.0
    else:
        lo, hi = default - 4.0 * abs(default) - 1.0, default + 4.0 * abs(default) + 1.0
    lo = lo if var.min is None else max(lo, var.min)
    hi = hi if var.max is None else min(hi, var.max)
    return st.one_of(st.just(float(default)), st.floats(lo, hi))


def _signal(var: Any) -> st.SearchStrategy[float]:
    """An input or initial-state element: small integers (they hit codes, ties and signs) or
    uniform in [-10, 10], within the declared min/max."""
    lo = -10.0 if var.min is None else max(-10.0, var.min)
    hi = 10.0 if var.max is None else min(10.0, var.max)
    ints = [float(i) for i in range(-1, 6) if lo <= i <= hi]
    return st.one_of(st.sampled_from(ints), st.floats(lo, hi)) if ints else st.floats(lo, hi)


def _value(var: Any, element: Any, length: int | None = None) -> st.SearchStrategy[Any]:
    if var.size is None:
        return element(var, var.start) if element is _element else element(var)
    n = var.size or (length if length is not None else len(var.start))
    starts = list(var.start) + [0.0] * (n - len(var.start))
    parts = [element(var, starts[i]) if element is _element else element(var) for i in range(n)]
    return st.tuples(*parts)


def _sized_first(cls: Any, params: dict[str, Any]) -> dict[str, Any]:
    """`params` with the sizing parameters first (they declare the ports the others fit)."""
    return dict(sorted(params.items(), key=lambda kv: kv[0] not in cls.sizing_parameters))


@st.composite
def case(draw: Any, kind: str) -> dict[str, Any]:
    """A variant, parameters, initial states, start, step and inputs for a block of `kind`.

    A class that has parameters this cannot draw (coefficient lists, sizes, a sign pattern, a
    period that must be a whole number of steps) offers `examples(h)`: parameter sets that suit
    steps of h [s]; one is drawn and its parameters are kept as given."""
    cls = lookup(kind)
    h = draw(st.one_of(st.just(1e-3), st.floats(-4.0, -1.3).map(lambda e: 10.0 ** e)))
    examples = getattr(cls, "examples", None)
    example = _sized_first(cls, draw(st.sampled_from(examples(h)))) if examples else {}
    twin = twin_of(kind) if kind in twins() else None
    order = draw(st.sampled_from(twin.orders)) if twin is not None and twin.orders else None
    sizing = {} if examples else {  # a block with examples is sized by them
        name: order or draw(st.sampled_from(SIZES)) for name in cls.sized_by.values()}
    proto = cls(kind, **_sized_first(cls, {**sizing, **example}))
    params: dict[str, Any] = dict(sizing)
    if twin is not None:
        for name, choice in twin.choices.items():
            params[name] = draw(st.sampled_from(list(choice.codes)))
    params.update(example)
    for name, var in proto.parameters.items():
        if var.type == BOOLEAN and name not in params and not (twin and name in twin.hidden):
            params[name] = draw(st.booleans())
    for name, var in proto.parameters.items():
        if var.type != REAL or (twin is not None and name in twin.hidden) or name in example:
            continue
        length = twin.lengths[name](order) if twin and order and name in twin.lengths else None
        params[name] = draw(_value(var, _element, length))
    if hasattr(cls, "example"):
        params = cls.example(params, h)
    states = {name: draw(_value(var, _signal)) for name, var in proto.outputs.items()
              if var.kind == "state"}
    n_steps = draw(st.integers(1, 25))
    held = [{name: draw(_value(var, _signal)) for name, var in proto.inputs.items()}
            for _ in range(draw(st.integers(1, 4)))]
    every = -(-(n_steps + 1) // len(held))
    inputs = [held[k // every] for k in range(n_steps + 1)]
    start = draw(st.one_of(st.just(0.0), st.floats(0.0, 5.0)))
    return {"params": _sized_first(cls, params), "states": states, "inputs": inputs, "h": h,
            "start": start}


# -- the three forms -------------------------------------------------------------------------
def _harness(kind: str, c: dict[str, Any]) -> Harness:
    h = Harness(kind, parameters=c["params"], initial=c["states"], start=c["start"],
                step=c["h"])
    h.set(**c["inputs"][0])
    return h.initialize()


def _flat(comp: Any) -> np.ndarray:
    """Every output and state element of `comp`, in declaration order."""
    return np.array([x for name in comp.outputs for x in np.ravel(comp.get(name))], dtype=float)


def python_form(kind: str, c: dict[str, Any]) -> np.ndarray:
    """Rows of outputs at each communication point from the component's methods."""
    with _harness(kind, c) as dut:
        comp, rows = dut.component, []
        for n, u in enumerate(c["inputs"]):
            t = c["start"] + n * c["h"]
            dut.set(**u)
            if comp.has_feedthrough:
                comp.evaluate(t)
            rows.append(_flat(comp))
            if n < len(c["inputs"]) - 1:
                comp.do_step(t, c["h"])
    return np.array(rows)


def _port(var: Any, value: Any) -> Any:
    return float(value) if var.size is None else tuple(float(v) for v in value)


def compiled_form(kind: str, c: dict[str, Any]) -> np.ndarray | None:
    """The same rows from the kernel functions (None: no kernel for this variant)."""
    with _harness(kind, c) as dut:
        comp = dut.component
        kern = comp.kernel(c["h"])
        if kern is None:
            return None
        x, p = kern.state, kern.params
        y = tuple(_port(v, comp.get(n)) for n, v in comp.outputs.items())
        rows = []
        for n, given in enumerate(c["inputs"]):
            t = c["start"] + n * c["h"]
            u = tuple(_port(v, v.coerce(given[name])) for name, v in comp.inputs.items())
            if comp.has_feedthrough:
                x, y = kern.evaluate(t, x, y, u, p)
            rows.append([e for v in y for e in np.ravel(v)])
            if n < len(c["inputs"]) - 1 and kern.step is not None:
                x, y = kern.step(t, c["h"], x, y, u, p)
    return np.array(rows, dtype=float)


@cache
def _fmu_folder() -> Path:
    import tempfile

    return Path(tempfile.mkdtemp(prefix="twmr-block-forms-"))


_FMUS: dict[tuple, Any] = {}


def _slave(kind: str, comp: Any, params: dict[str, Any], fmi: int) -> tuple[Any, list[Any]]:
    """The FMI `fmi` FMU of `comp`'s variant (exported and loaded once per session) and its
    elements."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    twin = twin_of(kind)
    elems = elements(comp, twin)
    key = (kind, tuple(sorted(twin.options(comp).items())), comp.has_feedthrough,
           tuple(e.name for e in elems), fmi)
    if key not in _FMUS:
        path = export_c_fmu(kind, _fmu_folder() / f"{kind}_{len(_FMUS)}.fmu", params, fmi=fmi)
        md = read_model_description(str(path))
        assert md.fmiVersion == f"{fmi}.0", md.fmiVersion
        fmu = (FMU2Slave if fmi == 2 else FMU3Slave)(
            guid=md.guid, unzipDirectory=extract(str(path)),
            modelIdentifier=md.coSimulation.modelIdentifier, instanceName=kind)
        fmu.instantiate()  # one instance per variant, reset for each example
        _FMUS[key] = fmu
    return _FMUS[key], elems


def c_form(kind: str, c: dict[str, Any], fmi: int = 2) -> np.ndarray:
    """The same rows from the block's C FMU (FMI `fmi`), every parameter and initial state set
    by FMI."""
    with _harness(kind, c) as dut:
        comp = dut.component
        fmu, elems = _slave(kind, comp, c["params"], fmi)
        put, get = (fmu.setReal, fmu.getReal) if fmi == 2 else (fmu.setFloat64, fmu.getFloat64)
        vr = {code: [i for i, e in enumerate(elems) if e.code in code] for code in ("ft", "s")}
        ins = {name: [i for i, e in enumerate(elems) if e.port == name] for name in comp.inputs}
        outs = [i for i, e in enumerate(elems) if e.code in "os"]

        def value(i: int) -> float:
            v = comp.get(elems[i].port) if elems[i].code in "ft" else c["states"][elems[i].port]
            return float(v if elems[i].index is None else v[elems[i].index])

        def write(u: dict[str, Any]) -> None:
            for name, refs in ins.items():
                put(refs, [float(x) for x in np.ravel(u[name])])

        fmu.reset()
        if fmi == 2:
            fmu.setupExperiment(startTime=c["start"])
        for code in ("ft", "s"):
            if vr[code]:
                put(vr[code], [value(i) for i in vr[code]])
        write(c["inputs"][0])
        if fmi == 2:
            fmu.enterInitializationMode()
        else:
            fmu.enterInitializationMode(startTime=c["start"])
        fmu.exitInitializationMode()
        rows = []
        for n, u in enumerate(c["inputs"]):
            write(u)
            rows.append(get(outs))
            if n < len(c["inputs"]) - 1:
                fmu.doStep(c["start"] + n * c["h"], c["h"])
        fmu.terminate()
    return np.array(rows, dtype=float)


# -- equality --------------------------------------------------------------------------------
def _names(kind: str, c: dict[str, Any]) -> list[str]:
    with _harness(kind, c) as dut:
        comp = dut.component
        return [f"{n}[{i + 1}]" if comp.variables[n].size is not None else n
                for n in comp.outputs for i in range(len(np.ravel(comp.get(n))))]


def _bits(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[np.isnan(a)] = np.nan  # one NaN pattern: a NaN's payload is not a result
    return a.view(np.uint64)


def assert_bit_identical(py: np.ndarray, comp: np.ndarray, names: list[str]) -> None:
    assert py.shape == comp.shape
    diff = np.argwhere(_bits(py) != _bits(comp))
    assert not len(diff), "python and compiled differ: " + "; ".join(
        f"{names[j]} at point {i}: {py[i, j]!r} != {comp[i, j]!r}" for i, j in diff[:5])


def assert_within(py: np.ndarray, c: np.ndarray, names: list[str]) -> None:
    assert py.shape == c.shape
    bad = []
    for j, name in enumerate(names):
        a, b = py[:, j], c[:, j]
        finite = np.isfinite(a)
        if not np.array_equal(a[~finite], b[~finite], equal_nan=True) or \
                not np.all(np.isfinite(b[finite])):
            bad.append(f"{name}: non-finite values differ (python {a}, C {b})")
            continue
        scale = max(1.0, float(np.max(np.abs(a[finite]), initial=0.0)))
        err = float(np.max(np.abs(a[finite] - b[finite]), initial=0.0))
        if err > REL * scale:
            i = int(np.argmax(np.abs(np.where(finite, a - b, 0.0))))
            bad.append(f"{name}: |C - python| = {err:.3g} > {REL:g} * {scale:.3g} (point {i}: "
                       f"python {a[i]!r}, C {b[i]!r})")
    assert not bad, "C twin differs from the Python block:\n" + "\n".join(bad)


@pytest.mark.parametrize("kind", KINDS)
def test_python_compiled_and_c_forms_are_equal(kind: str) -> None:
    @SETTINGS
    @given(case(kind))
    def check(c: dict[str, Any]) -> None:
        names = _names(kind, c)
        py = python_form(kind, c)
        comp = compiled_form(kind, c)
        if comp is not None:
            assert_bit_identical(py, comp, names)
        if kind in twins():
            assert_within(py, c_form(kind, c), names)

    check()


@pytest.mark.parametrize("kind", sorted(twins()))
def test_c_twins_exported_as_fmi3_equal_the_python_forms(kind: str) -> None:
    @SETTINGS_FMI3
    @given(case(kind))
    def check(c: dict[str, Any]) -> None:
        assert_within(python_form(kind, c), c_form(kind, c, fmi=3), _names(kind, c))

    check()


def _advances(kind: str) -> bool:
    """Whether the kernel of `kind` with its defaults has `advance`."""
    try:
        with Harness(kind).initialize() as dut:
            kern = dut.component.kernel(1e-3)
    except Exception:  # noqa: BLE001 - a kind that needs parameters to have a kernel
        return False
    return kern is not None and kern.advance is not None


ADVANCING = [k for k in KINDS if _advances(k)]


def test_the_paper_blocks_advance_without_their_outputs() -> None:
    assert {"asmc", "slip_disturbance"} <= set(ADVANCING), ADVANCING


def _bit_list(value: Any) -> list[int]:
    return [int(b) for b in _bits(np.array(list(_leaves(value)), dtype=float))]


def _leaves(value: Any) -> Any:
    if isinstance(value, tuple):
        for v in value:
            yield from _leaves(v)
    else:
        yield from np.ravel(value)


@pytest.mark.parametrize("kind", ADVANCING)
def test_advance_is_the_step_without_what_evaluate_recomputes(kind: str) -> None:
    """`Kernel.advance` gives every output that depends on no input as `step` does, bit for
    bit, and the state too (a block without feedthrough), or the next point's `evaluate` (with
    new inputs) gives the same state and outputs from either (a block with feedthrough, whose
    `evaluate` may set a state: the driver calls it before anything reads the block;
    tests/integration/test_driver_advance.py)."""
    @SETTINGS
    @given(case(kind))
    def check(c: dict[str, Any]) -> None:
        with _harness(kind, c) as dut:
            comp = dut.component
            kern = comp.kernel(c["h"])
            if kern is None or kern.advance is None:
                return
            x, p, h = kern.state, kern.params, c["h"]
            y = tuple(_port(v, comp.get(n)) for n, v in comp.outputs.items())
            kept = [j for j, v in enumerate(comp.outputs.values()) if not v.depends_on]

            def inputs(n: int) -> tuple:
                return tuple(_port(v, v.coerce(c["inputs"][n][name]))
                             for name, v in comp.inputs.items())

            for n in range(len(c["inputs"]) - 1):
                t = c["start"] + n * h
                if comp.has_feedthrough:
                    x, y = kern.evaluate(t, x, y, inputs(n), p)
                xs, ys = kern.step(t, h, x, y, inputs(n), p)
                xa, ya = kern.advance(t, h, x, y, inputs(n), p)
                if not comp.has_feedthrough:
                    assert _bit_list(xa) == _bit_list(xs), (n, xa, xs)
                for j in kept:
                    assert _bit_list(ya[j]) == _bit_list(ys[j]), (n, j, ya[j], ys[j])
                if comp.has_feedthrough:
                    after = [kern.evaluate(t + h, xx, yy, inputs(n + 1), p)
                             for xx, yy in ((xs, ys), (xa, ya))]
                    assert _bit_list(after[0]) == _bit_list(after[1]), (n, after)
                x, y = xs, ys

    check()


def test_every_c_twin_belongs_to_a_block_and_has_its_source() -> None:
    for kind in twins():
        assert kind in kinds(), f"C twin '{kind}' has no component kind"
        for path in (twin_of(kind).source, *twin_of(kind).headers):
            assert path.is_file(), path
