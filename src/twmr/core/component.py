"""`Component`: one interface for every block, shaped like an FMI 2.0 co-simulation slave.

Life cycle: ``prepare(run)`` → ``setup(start, stop)`` → ``initialize()`` → at each
communication point t the master writes the inputs, calls ``evaluate(t)`` when the component
has direct feedthrough, then ``do_step(t, h)`` → ... → ``terminate()``.

Semantics (what the master relies on):
- after ``initialize()`` the outputs hold their values at the start time;
- ``evaluate(t)`` recomputes the direct-feedthrough outputs from the inputs just written, at time t
  (FMI: fmi2GetReal after fmi2SetReal);
- ``do_step(t, h)`` advances from t to t + h with the inputs held (zero-order hold) and leaves the
  state-dependent outputs at t + h.

A block that offers a kernel (a method ``kernel(h)`` returning a `twmr.core.kernel.Kernel`) needs
nothing else: its ``evaluate``/``do_step`` run the kernel's functions (`kernel_evaluate`,
`kernel_do_step`), the component holding the kernel's private state between calls, and the
compiled loop calls the same functions.
"""
from __future__ import annotations

import dataclasses
import functools
import numbers
from collections.abc import Callable, Mapping
from pathlib import Path
from types import FunctionType, MappingProxyType
from typing import Any, ClassVar, NamedTuple

from twmr.core.errors import ComponentError
from twmr.core.kernel import Kernel, KernelFunction, compiled_pays, python_params
from twmr.core.port import Input, Output, Parameter, State, Variable
from twmr.core.run import RunContext

#: what a saved state may hold: values that are immutable and pickle (tuples of them nest)
PLAIN = (type(None), numbers.Number, str, bytes)
#: a saved state: (name, value) for each input, output, state and `state_attributes` entry
SavedState = tuple[tuple[str, Any], ...]


def plain(value: Any) -> bool:
    """Whether `value` is a plain immutable value (see `PLAIN`), a numpy array (saved as a
    copy) or a tuple of them."""
    if isinstance(value, tuple):
        return all(plain(v) for v in value)
    return isinstance(value, PLAIN) or type(value).__name__ == "ndarray"


def _frozen(value: Any) -> Any:
    """`value` with every numpy array in it copied, so a saved state does not change later."""
    if isinstance(value, tuple):
        items = [_frozen(v) for v in value]
        return type(value)(*items) if hasattr(value, "_fields") else tuple(items)
    return value.copy() if type(value).__name__ == "ndarray" else value


#: attributes of a component that runs a kernel: its private state x (`KERNEL_STATE`, which the
#: schedule reads), and its `_Calls`
KERNEL_STATE, _CALLS = "_kernel_x", "_kernel_calls"


def _python(fn: Any, long: bool = False) -> Any:
    """What a Python call runs of kernel function `fn`: a `kernel_function`'s Python form
    (`KernelFunction.python`; `long`: the run repays loading numba), a numba function
    compiled."""
    return fn.python(long) if isinstance(fn, KernelFunction) else fn


class PythonKernel(NamedTuple):
    """What a Python loop needs to call a component's kernel itself (`python_kernel`): the
    parameter table as the functions read it (`twmr.core.kernel.python_params`), the functions
    evaluate, step and advance (`Kernel.advance`) in their Python form (any None), and
    `sync(x)`, which hands the private state x back to the component and runs the block's own
    report."""

    params: Any
    evaluate: Callable[..., Any] | None
    step: Callable[..., Any] | None
    advance: Callable[..., Any] | None
    sync: Callable[[Any], None]


class _Calls:
    """A component's Python calls of its kernel: two functions `evaluate(t)` and `step(t, h)`,
    generated once per instance for its ports (values read from and written to its `__dict__` by
    name), whose globals hold the kernel in use: the kernel is made at the first call, again when
    `step` is given another h, and after `reset()` (a new run). The functions stay the same
    objects, so the step loop binds them once (see `_KernelMethod`). `bound` is the kernel in
    use for a loop that calls it itself (`python_kernel`)."""

    def __init__(self, comp: Component):
        self.comp = comp
        d = comp.__dict__

        def ports(names: list[str]) -> str:
            return "(" + "".join(f"d[{n!r}], " for n in names) + ")"

        ys, us = ports(list(comp.outputs)), ports(list(comp.inputs))
        env: dict[str, Any] = {"d": d, "load": self.load, "H": None, "p": None, "ev": None,
                               "st": None, "report": None}
        self.env = env
        lines = []
        for name, fn, args in (("evaluate", "ev", "t"), ("step", "st", "t, h")):
            lines += [f"def {name}({args}):",
                      "    if H is None: load(0.0)" if fn == "ev" else "    if h != H: load(h)",
                      f"    if {fn} is None: return",
                      f"    x0 = d[{KERNEL_STATE!r}]",
                      f"    x, {ys} = {fn}({args}, x0, {ys}, {us}, p)",
                      "    if x is x0: return",
                      f"    d[{KERNEL_STATE!r}] = x",
                      "    if report is not None: report(x)"]
        lines += ["def sync(x):",
                  f"    d[{KERNEL_STATE!r}] = x",
                  "    if report is not None: report(x)"]
        exec("\n".join(lines), env)  # noqa: S102 - generated here from port names
        self.functions: dict[str, Callable[..., None]] = {"evaluate": env["evaluate"],
                                                          "step": env["step"]}
        for function in self.functions.values():
            function.calls = self  # type: ignore[attr-defined]
        self.bound: PythonKernel | None = None

    def make(self, h: float) -> PythonKernel | None:
        """The kernel made for steps of `h` [s] put in the functions' globals and `bound`, the
        component holding its private state from now on; None (nothing changed) when the
        component offers none with these parameters, or only an FMU's."""
        comp = self.comp
        make = getattr(comp, "kernel", None)
        k = make(h) if make is not None else None
        if k is None or k.fmu is not None:
            return None
        comp.__dict__.setdefault(KERNEL_STATE, k.state)
        p = python_params(k.params, (k.evaluate, k.step, k.advance))
        long = h > 0.0 and compiled_pays(_steps(comp, h))
        ev, st, ad = _python(k.evaluate, long), _python(k.step, long), _python(k.advance, long)
        self.env.update(H=h, p=p, ev=ev, st=st,
                        report=getattr(k.sync, "__wrapped__", k.sync))  # the block's own sync
        self.bound = PythonKernel(p, ev, st, ad, self.env["sync"])
        return self.bound

    def load(self, h: float) -> None:
        """`make(h)` for the component's own calls (h = 0: before the first step, for
        `evaluate`, which must not depend on it); TypeError when there is no kernel."""
        if self.make(h) is None:
            comp = self.comp
            raise TypeError(
                f"component '{comp.name}' ({type(comp).__name__}) offers no kernel with these "
                f"parameters and has no evaluate/do_step of its own. Fix: give the class "
                f"Python methods for the parameters its kernel does not cover.")

    def reset(self) -> None:
        self.env["H"] = None


def _steps(comp: Component, h: float) -> float:
    """How many steps of `h` [s] the run `comp` was set up for has (0: not set up, or no stop
    time)."""
    stop = getattr(comp, "stop_time", None)
    return 0.0 if stop is None else (stop - comp.start_time) / h


#: (method, the `_KernelMethod` it must be on the class, the `_Calls` function it runs)
_BOUND = (("evaluate", "kernel_evaluate", "evaluate"), ("do_step", "kernel_do_step", "step"),
          ("kernel_evaluate", "kernel_evaluate", "evaluate"),
          ("kernel_do_step", "kernel_do_step", "step"))


def _calls(comp: Component) -> _Calls:
    """The `_Calls` of `comp`, made on first use, its functions then bound on the instance to
    each method of its class that is the `_KernelMethod` running them (so a call skips the
    descriptor and this look-up; a copy or a pickle of the component leaves them out, see
    `Component.__getstate__`)."""
    d = comp.__dict__
    calls = d.get(_CALLS)
    if calls is None:
        calls = d[_CALLS] = _Calls(comp)
        cls = type(comp)
        for method, kernel_method, which in _BOUND:
            if method not in d and getattr(cls, method) is getattr(Component, kernel_method):
                d[method] = calls.functions[which]
    return calls


def _calls_of(fn: Any) -> _Calls | None:
    """The `_Calls` whose function `fn` is (None: not one)."""
    return getattr(fn, "calls", None) if isinstance(fn, FunctionType) else None


def replaced_on_instance(comp: Component) -> bool:
    """Whether `evaluate` or `do_step` of `comp` is replaced on the instance (by anything but
    the functions `_calls` binds there for it)."""
    d = comp.__dict__
    return any(m in d and _calls_of(d[m]) is not d.get(_CALLS, False)
               for m in ("evaluate", "do_step"))


def runs_kernel(comp: Component) -> bool:
    """Whether a loop may call the kernel of `comp` instead of its `evaluate`/`do_step`: its
    class defines `kernel` and neither a subclass of that class nor the instance replaces the
    methods the kernel mirrors (those would be definitions of their own)."""
    if replaced_on_instance(comp):
        return False
    owner = next((k for k in type(comp).__mro__ if "kernel" in vars(k)), None)
    return owner is not None and callable(vars(owner)["kernel"]) and all(
        getattr(type(comp), m) is getattr(owner, m) for m in ("evaluate", "do_step"))


def python_kernel(comp: Component, h: float) -> PythonKernel | None:
    """The kernel `comp` runs with steps of `h` [s] (made again only after a new run's `setup`
    or a restore to before the first step), for a loop that calls its functions itself and
    hands the state back through `sync`; None when `runs_kernel` is false or the component
    offers no kernel (or only an FMU's) with these parameters."""
    return bound_kernel(comp, h) if runs_kernel(comp) else None


def parameters_changed(comp: Component) -> None:
    """`comp`'s parameters were set during a run: its kernel is made anew, from them, at its
    next call (the private state it holds is kept)."""
    calls = comp.__dict__.get(_CALLS)
    if calls is not None:
        calls.reset()


def bound_kernel(comp: Component, h: float) -> PythonKernel | None:
    """`python_kernel` without asking `runs_kernel` again (a loop generated for it asks once)."""
    calls = _calls(comp)
    if calls.env["H"] == h and calls.bound is not None:
        return calls.bound
    return calls.make(h)


class _KernelMethod:
    """`kernel_evaluate` / `kernel_do_step`: on an instance, its `_Calls` function (made on first
    use), called directly; on the class, this object."""

    def __init__(self, which: str, doc: str):
        self.which = which
        self.__doc__ = doc

    def __get__(self, comp: Component | None, cls: type | None = None) -> Any:
        if comp is None:
            return self
        return _calls(comp).functions[self.which]


def _holding(make: Callable[[Any, float], Kernel | None]) -> Callable[[Any, float], Kernel | None]:
    """`kernel(h)` of a block, handing out the private state the component holds (so compiled
    steps continue where Python ones stopped) and keeping the state compiled steps leave."""
    @functools.wraps(make)
    def kernel(self: Component, h: float) -> Kernel | None:
        k = make(self, h)
        if k is None or k.fmu is not None:
            return k
        d = self.__dict__
        x = d.setdefault(KERNEL_STATE, k.state)
        report = k.sync

        def sync(x: tuple) -> None:
            d[KERNEL_STATE] = x
            if report is not None:
                report(x)
        sync.__wrapped__ = report  # type: ignore[attr-defined]
        return dataclasses.replace(k, state=x, sync=sync)
    return kernel


class Component:
    """Base class of native blocks. Subclasses declare `Input`/`Output`/`Parameter`/`State`
    descriptors and override the life-cycle methods they need."""

    kind: ClassVar[str] = ""
    #: whether `get_state`/`set_state` work (False: hardware, or an FMU that says it cannot)
    can_get_and_set_state: bool = True
    #: private attributes that `do_step` changes beyond the declared variables (e.g. a kernel's
    #: internal state), saved by `get_state`; each must hold a plain value (see `PLAIN`)
    state_attributes: ClassVar[tuple[str, ...]] = ()
    #: parameters needed to construct the instance (e.g. an FMU's `path`), given to `create`
    construction_parameters: ClassVar[tuple[str, ...]] = ()
    #: hardware in the loop: runs are paced to the wall clock unless the scenario says otherwise
    needs_realtime: ClassVar[bool] = False
    #: parameters that size other ports (FMI 3.0 structural parameters): set before the others
    sizing_parameters: frozenset[str] = frozenset()
    #: other names of a variable (an FMU's aliases): alias -> the port it names; never set
    aliases: Mapping[str, str] = MappingProxyType({})
    #: bus terminals (FMI-LS-BUS network terminals): name -> {member: port}, members Tx_Data,
    #: Tx_Clock, Rx_Data, Rx_Clock; a wire `a.T -> b.U` joins each Tx member to the other's Rx
    terminals: Mapping[str, Mapping[str, str]] = MappingProxyType({})
    #: when `terminate()` comes among the others': 0 first (a bus terminal's host, whose last
    #: frames stop its drives), 1 a bus that carries those frames, 2 a device that hears them
    terminate_stage: ClassVar[int] = 0
    #: the block's C twin for a standalone C FMU (`twmr export KIND`;
    #: `twmr.core.ctwin.CTwin`), or None
    c_twin: ClassVar[Any] = None
    #: element-wise blocks: variable -> the whole-number parameter that gives its size (1: a
    #: scalar, n > 1: a vector of n, its start value repeated)
    sized_by: ClassVar[dict[str, str]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A class that defines `kernel` gets `evaluate`/`do_step` that run it (unless it, or a
        base, has its own), and its `kernel(h)` carries the state the component holds."""
        super().__init_subclass__(**kwargs)
        if cls.sized_by:
            cls.sizing_parameters = cls.sizing_parameters | frozenset(cls.sized_by.values())
        make = vars(cls).get("kernel")
        if make is None or not callable(make):
            return
        setattr(cls, "kernel", _holding(make))  # noqa: B010 - Component declares no `kernel`
        if cls.evaluate is Component.evaluate:
            cls.evaluate = Component.kernel_evaluate  # type: ignore[method-assign]
        if cls.do_step is Component.do_step:
            cls.do_step = Component.kernel_do_step  # type: ignore[method-assign]

    def __init__(self, name: str = "", **parameters: Any):
        self.name = name or type(self).__name__
        self.variables: dict[str, Variable] = self.declared()
        for var in self.variables.values():
            self.__dict__[var.name] = var.start
        for key, value in parameters.items():
            self.set_parameter(key, value)

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> Component:
        """Make an instance for a scenario; `construction` holds the values of
        `construction_parameters`, and relative file paths resolve against `base_dir`."""
        return cls(name, **construction)

    # -- interface description ---------------------------------------------------------------
    @classmethod
    def declared(cls) -> dict[str, Variable]:
        """The class's variables in declaration order, base classes first; a subclass that sets
        a base's variable to None has no such variable."""
        found: dict[str, Variable] = {}
        for klass in reversed(cls.__mro__):
            for key, value in vars(klass).items():
                if isinstance(value, Variable):
                    found[key] = value
                elif value is None and key in found:
                    del found[key]
        return found

    @classmethod
    def added_parameters(cls) -> dict[str, dict[str, Variable]]:
        """Parameters an instance has beyond the declared ones, by the setting that adds them
        (e.g. 'protocol: odrive' -> its options), for listings."""
        return {}

    def _of(self, kind: str) -> dict[str, Variable]:
        return {n: v for n, v in self.variables.items() if v.kind == kind}

    @property
    def inputs(self) -> dict[str, Input]:
        return self._of("input")  # type: ignore[return-value]

    @property
    def outputs(self) -> dict[str, Output]:
        """Outputs and states: every variable another component may read."""
        return {n: v for n, v in self.variables.items()  # type: ignore[misc]
                if v.kind in ("output", "state")}

    @property
    def parameters(self) -> dict[str, Parameter]:
        return self._of("parameter")  # type: ignore[return-value]

    @property
    def states(self) -> dict[str, State]:
        return self._of("state")  # type: ignore[return-value]

    @property
    def has_feedthrough(self) -> bool:
        """True when some output depends directly on some input (then `evaluate` is called)."""
        return any(o.depends_on for o in self.outputs.values())

    # -- values ------------------------------------------------------------------------------
    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        """Problems with the parameters as a whole, found when the scenario is built (`twmr
        check`): (parameter at fault or '', what is wrong, how to fix it). `given` names the
        parameters the scenario set (the others hold their defaults)."""
        return []

    def check_peers(self, peers: Mapping[str, Component]) -> list[tuple[str, str, str]]:
        """Problems that involve the other components of the same system (`peers`, by instance
        name, this one included), such as a parameter naming another component, found when the
        scenario is built, as `check`'s."""
        return []

    def open_terminal(self, name: str, peer: Component, terminal: str) -> Mapping[str, str] | None:
        """A wire joins bus terminal `terminal` of `peer` to `name` of this block, which has no
        terminal `name`: the members (member -> port) of the terminal this block opens for it
        (a bus block opens one per participant), or None (it opens none). ValueError says why
        it refuses."""
        return None

    def unknown_parameter(self, name: str) -> tuple[str, str] | None:
        """What `name`, which this component does not have, is instead, and the fix (e.g. an
        option of another protocol); None: nothing to say beyond the known names."""
        return None

    def bodies(self) -> dict[str, dict[str, float]]:
        """Output port holding a planar pose (x, y, heading) -> the dimensions [m] of the
        vehicle it moves, for 3D views: `wheel_radius`, `half_track`, `length`, `width`,
        `height`, `ahead` (how far the body's centre is ahead of the pose's point); {}: none."""
        return {}

    def stopping(self) -> None:
        """The run has stopped stepping (completed, failed or stopped): called on every
        component before any `terminate`, so that what the stops send can pass (a bus ends its
        injected faults here)."""

    def hold(self, t: float) -> None:
        """Called every 50 ms while the run is paused at time t [s] (`twmr.master.gate`):
        hardware keeps itself safe here (a drive sends zero torque, feeding its watchdog)."""

    def vectors(self) -> dict[str, list[dict[str, Any]]]:
        """Output port holding a planar pose -> the vectors 3D views draw on its vehicle, each
        `{"label", "port", "element", "at", "along", "scale"[, "colour"]}`: element `element`
        (0-based) of this block's port `port` (an input or output, drawn when recorded) as an
        arrow from `at` (x ahead, y left, z up [m], in the vehicle's frame) along the unit
        vector `along`, `scale` [m] long per unit of the port, in `colour` ('#RRGGBB', default
        green); {}: none."""
        return {}

    def limits(self) -> dict[str, tuple[float, float]]:
        """Output port -> (lowest, highest) value its parameters allow it (a torque limit), for
        plots to draw; {}: none."""
        return {}

    def check_step(self, h: float) -> list[tuple[str, str, str]]:
        """Problems of the parameters with communication steps of h [s] (the base step times
        the component's step_multiple), found when the scenario is built, as `check`'s."""
        return []

    def set_parameter(self, name: str, value: Any) -> None:
        """Set a parameter or a start value (input, state) before `initialize()`.

        Raises KeyError for an unknown name and ValueError/TypeError for a value that does not
        fit."""
        var = self.variables[name]
        self.__dict__[name] = var.coerce(value)
        if name in self.sizing_parameters and self.sized_by:
            self._size_from(name)

    def _size_from(self, parameter: str) -> None:
        """The variables `sized_by` `parameter` take its present value as their size."""
        n = self.__dict__[parameter]
        if isinstance(n, bool) or not isinstance(n, (int, float)) or n != int(n) or n < 1:
            raise ValueError(f"a size must be a whole number of at least 1, not {n!r}")
        size = None if n == 1 else int(n)
        for key, by in self.sized_by.items():
            var = self.variables[key]
            if by != parameter or var.size == size:
                continue
            first = var.start[0] if isinstance(var.start, tuple) else var.start
            resized = dataclasses.replace(var, size=size,
                                          start=first if size is None else (first,) * size)
            resized.name = key
            self.variables[key] = resized
            self.__dict__[key] = resized.start

    def get(self, name: str) -> Any:
        """Current value of any variable."""
        return self.__dict__[name]

    def clock_of(self, port: str) -> str | None:
        """The clock port that ticks when Binary `port` holds new data (a bus terminal's
        Tx_Clock for its Tx_Data, Rx_Clock for its Rx_Data); None: it has none."""
        for members in self.terminals.values():
            for data, clock in (("Tx_Data", "Tx_Clock"), ("Rx_Data", "Rx_Clock")):
                if members.get(data) == port and clock in members:
                    return members[clock]
        return None

    # -- life cycle (FMI 2.0 co-simulation) ---------------------------------------------------
    def prepare(self, run: RunContext) -> None:
        """Called first with the run's `RunContext` (`twmr.core.run`): `run.folder` is where
        the component may write files of its own (None: the run writes nothing), `run.step` the
        base step [s], `run.paced` whether steps follow the wall clock, and what the algorithm
        does as capabilities (`outputs_as_stepped`, `steps_retaken`), never its name."""

    def setup(self, start: float, stop: float | None) -> None:
        """Called once before `initialize()` with the experiment's start and stop times [s]."""
        self.start_time = start
        self.stop_time = stop
        # a kernel's private state starts again from its `state`
        self.__dict__.pop(KERNEL_STATE, None)
        calls = self.__dict__.get(_CALLS)
        if calls is not None:
            calls.reset()  # the kernel made again from the parameters of this run

    def initialize(self) -> None:
        """Compute the outputs at the start time from parameters, states and inputs."""

    def evaluate(self, t: float) -> None:
        """Recompute direct-feedthrough outputs from the current inputs at time t [s]."""

    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h [s] with inputs held; leave outputs at t + h."""

    kernel_evaluate = _KernelMethod("evaluate", """`evaluate(t)` of a block that offers a
        kernel: its `evaluate` function on (held state, outputs, inputs, parameters), the
        outputs written back. Before the first step the kernel is made with h = 0 (the step is
        not known yet; evaluate must not depend on it).""")
    kernel_do_step = _KernelMethod("step", """`do_step(t, h)` of a block that offers a kernel:
        its `step` function from t to t + h [s] (the kernel made again when h changes), the
        outputs written back.""")

    def next_event(self, t: float) -> float | None:
        """The first time > t [s] at which the outputs jump (a time event; None: none known);
        the adaptive master ends a step there (`twmr.master.adaptive`)."""
        return None

    #: set by a master that locates state events (`twmr.master.adaptive`) before `setup`: a
    #: state event found at the very end of a `do_step` waits for `event`
    hold_events = False
    #: set by that master before a `do_step` it will take again to end at a state event met
    #: inside it, to a tolerance [s]: a state event more than this after the step's start and
    #: before its end may end the step there, unhandled (`state_event` says when); None: never
    stop_at_events: float | None = None

    def state_event(self) -> float | None:
        """After `do_step`: the time [s] of the first state event it met inside its step, one
        at the step's end included (None: none); the adaptive master steps to it."""
        return None

    def event(self, t: float) -> None:
        """Handle a state event held at the end of the last step, at t [s] (`hold_events`):
        the outputs from before it to after it. Nothing when none is held."""

    def events_unseen(self) -> str | None:
        """Why events inside this component's steps are hidden from a master that locates them
        (None: they are not: it has none, or announces them through `state_event`,
        `early_event`, `next_event` or a non-Real output that changes)."""
        return None

    def controls_its_error(self) -> bool:
        """Whether the outputs of `do_step` are integrated to a tolerance of its own (a
        model-exchange FMU under CVODE), so a master that estimates errors by step doubling
        watches them only where they feed another component (the coupling error)."""
        return False

    def repeats_steps(self) -> bool:
        """Whether the last `do_step`, taken again from the state saved just before it, ends as
        it did (False: a model-exchange FMU whose solver went on with the history it had at the
        save; taken again, it restarts there, and a state event may move within the tolerance).
        A master that steps to a located event retakes such a step first."""
        return True

    def early_event(self) -> float | None:
        """The time [s] of an event the last `do_step` met inside its step that could not be
        known before it (an FMU's early return), or None; `algorithm: adaptive` retakes the
        step to end at the grid point at or after it."""
        return None

    def terminate(self) -> None:
        """Release resources; called once, also after an error."""

    def last_sent(self, terminal: str) -> bytes:
        """The bus operations bus terminal `terminal` sent as it terminated (a CAN node's
        frames that stop its drives), read by its bus after `terminate()`; b'' for none."""
        return b""

    def report(self) -> dict[str, Any]:
        """Figures about the run so far (e.g. round-trip times), collected after it ends."""
        return {}

    def get_state(self) -> Any:
        """A snapshot of everything `do_step` changes (FMI fmi2GetFMUstate): by default the
        values of the inputs, outputs and states and of the `state_attributes`, as a tuple of
        (name, value) pairs that pickles. Raises `ComponentError` if the block cannot."""
        if not self.can_get_and_set_state:
            raise self.no_state("save")
        d = self.__dict__
        saved = tuple((n, _frozen(d[n])) for n in self._state_names())
        for name, value in saved:
            if not plain(value):
                raise ComponentError(self.name, None, f"cannot save its state: '{name}' holds "
                                     f"a {type(value).__name__}, not a plain value. Fix: keep "
                                     f"it as a number, a string, bytes or a tuple of them (or "
                                     f"override get_state/set_state in {type(self).__name__}).")
        return saved

    def set_state(self, state: Any) -> None:
        """Restore a snapshot taken by `get_state` (FMI fmi2SetFMUstate)."""
        if not self.can_get_and_set_state:
            raise self.no_state("restore")
        names = tuple(n for n, _ in state) if isinstance(state, tuple) else None
        d = self.__dict__
        if names is not None and KERNEL_STATE in d and _CALLS in d and \
                names == self._state_names()[:-1]:
            # saved before the kernel's first step: it starts again from the kernel's own state
            del d[KERNEL_STATE]
            d[_CALLS].reset()
        elif names != self._state_names():
            raise ComponentError(self.name, None, f"the state given to set_state was not "
                                 f"saved by a {type(self).__name__} with these ports. Fix: "
                                 f"restore only states that this component's get_state "
                                 f"returned.")
        d.update((n, _frozen(v)) for n, v in state)

    def _state_names(self) -> tuple[str, ...]:
        """What a saved state holds: the ports and states, the `state_attributes`, and the
        private state of the kernel the block runs (when it runs one)."""
        names = [n for n, v in self.variables.items() if v.kind != "parameter"]
        kernel = (KERNEL_STATE,) if KERNEL_STATE in self.__dict__ else ()
        return (*names, *self.state_attributes, *kernel)

    def release_state(self, state: Any) -> None:
        """The caller no longer needs `state` (FMUs free what it holds); by default nothing."""

    def no_state(self, what: str) -> ComponentError:
        """The error for a block that cannot `what` ('save' or 'restore') its state."""
        return ComponentError(self.name, None, f"a {self.kind or type(self).__name__} cannot "
                              f"{what} its state (can_get_and_set_state is false). Fix: use an "
                              f"algorithm that does not roll steps back with this component.")

    def why_no_state(self) -> str:
        """Why this block cannot save its state, in a few words (for `twmr check`)."""
        return "its can_get_and_set_state is false, as for hardware in the loop"

    def __getstate__(self) -> dict[str, Any]:
        """What a copy or a pickle of the component holds: its attributes without its kernel's
        Python calls (functions reading this instance's values; a copy makes its own)."""
        return {k: v for k, v in self.__dict__.items()
                if k != _CALLS and _calls_of(v) is None}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}>"


__all__ = ["Component", "Input", "Output", "Parameter", "State"]
