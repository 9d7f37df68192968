"""FMI 3.0 co-simulation in event mode: clocks, clocked variables and early return.

An FMU whose co-simulation interface has `hasEventMode="true"` is instantiated with
`eventModeUsed` and `earlyReturnAllowed`. Its clocks are ports of type Clock, True at the
communication point where they ticked:

- an output clock, and an input clock the FMU schedules itself (periodic: `constant`, `fixed`,
  `tunable`, `changing`; or `countdown`), is an output port: the importer activates the scheduled
  ones at the times the FMU's intervals give (`fmi3GetIntervalDecimal`, after every event);
- a triggered input clock is an input port: when its source ticks, the FMU enters event mode at
  that communication point, its clocked inputs are set and the clock is activated.

An event (the FMU's `eventHandlingNeeded`, an early return, a scheduled clock due, a time event
from `fmi3UpdateDiscreteStates`) is handled at the FMU's own time inside the communication
step: enter event mode, activate input clocks and set their clocked inputs, get the output
clocks and the variables they clock, update the discrete states until they settle, read the
clocks' new intervals, return to step mode, and step on to the communication point. The doStep
is split at every scheduled tick, so a countdown clock ticks at its own time. What ticked is
visible to the other components at the end of the communication step; a Binary output of a bus
terminal that ticks twice in one step carries the operations of both ticks, back to back, as a
`TickedData` that keeps each tick's time (for a bus that reads it at the communication point).
"""
from __future__ import annotations

import ctypes
import math
from typing import TYPE_CHECKING

from twmr.core.errors import FmuError
from twmr.fmi.description import clock_timing
from twmr.fmi.direct import event_stepper
from twmr.fmi.lsbus.ticks import TickedData

if TYPE_CHECKING:
    from twmr.fmi.description import FmuPort
    from twmr.fmi.fmu import EventHost

#: how many fmi3UpdateDiscreteStates calls one event may take before it is called a loop
MAX_ITERATIONS = 100
_QUALIFIER_CHANGED = 2


class EventMode:
    """The event-mode part of one FMI 3.0 co-simulation FMU (see the module docstring)."""

    def __init__(self, comp: EventHost):
        self.comp = comp
        ports = comp.ports
        self.in_clocks = [p for p in ports if p.clock and p.kind == "input"]
        self.out_clocks = [p for p in ports if p.clock and p.kind == "output" and not p.scheduled]
        self.scheduled = [p for p in ports if p.scheduled]
        self.clock_ports = [p for p in ports if p.clock]
        self.clocked_in = [p for p in ports if p.clocked_by and p.kind == "input"]
        self.clocked_out = [p for p in ports if p.clocked_by and p.kind in ("output", "state")]
        timing = clock_timing(comp.source_path)
        #: periodic clocks of constant interval: name -> (interval, shift) [s]
        self._periodic = {p.name: timing[p.vrs[0]] for p in self.scheduled
                          if p.clock == "constant" and p.vrs[0] in timing}
        #: shift [s] of the other periodic clocks, and their interval once the FMU gave it
        self._shift = {p.name: timing.get(p.vrs[0], (0.0, 0.0))[1] for p in self.scheduled}
        self._period: dict[str, float] = {}
        #: within one communication step: the clocked outputs already got (bus data appends)
        self._fresh: set[str] = set()
        #: every tick: (time [s], clock port)
        self.ticks: list[tuple[float, str]] = []
        #: the first early return inside the last step [s]
        self.early: float | None = None
        #: no clock at all: a step is doStep and the events it asks for (`_step_plain`)
        self.clockless = not self.clock_ports
        instance = comp.instance
        self._do_step = event_stepper(instance) or instance.doStep

    # -- times -------------------------------------------------------------------------------
    def due(self) -> dict[str, float]:
        return dict(self.comp.clock_due)

    def _set_due(self, due: dict[str, float]) -> None:
        self.comp.clock_due = tuple(sorted(due.items()))

    def next_time(self) -> float:
        """The first scheduled tick or time event [s] (inf: none)."""
        times = [t for _, t in self.comp.clock_due]
        return min([*times, self.comp.time_event])

    def due_at(self, t: float) -> list[FmuPort]:
        tol = _tol(t)
        due = self.due()
        return [p for p in self.scheduled if p.name in due and due[p.name] <= t + tol]

    # -- one communication step --------------------------------------------------------------
    def step(self, t: float, h: float) -> None:
        """doStep from t to t + h [s], with every event on the way handled at its own time."""
        if self.clockless:
            self._step_plain(t, h)
            return
        c = self.comp
        d = c.values
        for p in self.clock_ports:
            if p.kind == "output":
                d[p.name] = False
        self._fresh = set()
        self.early = None
        ticked = [p for p in self.in_clocks if d[p.name]]
        if ticked:
            self._handle(t, ticked, self.due_at(t))
        end, now, stalled = t + h, t, 0
        while now < end - _tol(end):
            stop = min(end, self.next_time())
            if stop <= now + _tol(now):
                stop = end
            c.now = now
            needed, terminate, early, last = c.call("fmi3DoStep", self._do_step, now,
                                                    stop - now)
            if terminate:
                raise FmuError(c.name, last if early else stop, f"FMU '{c.path.name}' asked to "
                               f"terminate the simulation (fmi3DoStep terminateSimulation).",
                               c.log.tail())
            reached = last if early else stop
            stalled = stalled + 1 if reached <= now + _tol(now) else 0
            if stalled > MAX_ITERATIONS or (stalled and not needed):
                self._stalled(now, reached, stalled, needed)
            if early and self.early is None and reached < end - _tol(end):
                self.early = reached
            now = max(now, reached)
            c.now = now
            due = self.due_at(now)
            timed = c.time_event <= now + _tol(now)
            if needed or early or due or timed:
                self._handle(now, [], due)

    def _step_plain(self, t: float, h: float) -> None:
        """`step` of an FMU without clocks: its time events and the events doStep asks for are
        all there is (the same calls at the same times as `step`, without the clocks'
        bookkeeping)."""
        c = self.comp
        self.early = None
        end, now, stalled = t + h, t, 0
        last_point = end - _tol(end)
        while now < last_point:
            stop = min(end, c.time_event)
            if stop <= now + _tol(now):
                stop = end
            c.now = now
            needed, terminate, early, last = c.call("fmi3DoStep", self._do_step, now,
                                                    stop - now)
            if terminate:
                raise FmuError(c.name, last if early else stop, f"FMU '{c.path.name}' asked to "
                               f"terminate the simulation (fmi3DoStep terminateSimulation).",
                               c.log.tail())
            reached = last if early else stop
            stalled = stalled + 1 if reached <= now + _tol(now) else 0
            if stalled > MAX_ITERATIONS or (stalled and not needed):
                self._stalled(now, reached, stalled, needed)
            if early and self.early is None and reached < last_point:
                self.early = reached
            now = max(now, reached)
            c.now = now
            if needed or early or c.time_event <= now + _tol(now):
                self._handle(now, [], [])

    def _stalled(self, now: float, reached: float, stalled: int, needed: bool) -> None:
        c = self.comp
        raise FmuError(c.name, now, f"FMU '{c.path.name}' returned early from fmi3DoStep at "
                       f"t = {reached:.9g} s without progress ({stalled} time(s) in a row"
                       f"{'' if needed else ', without an event'}). Fix: see the FMU's log (its "
                       f"vendor should not return early without progress).", c.log.tail())

    def _handle(self, t: float, ticked: list[FmuPort], scheduled: list[FmuPort]) -> None:
        """Event mode at t [s]: one event, then one more for every clock that became due at
        that instant (a countdown of 0 s), then back to step mode."""
        c, f = self.comp, self.comp.instance
        c.call("fmi3EnterEventMode", f.enterEventMode)
        self._instant(t, ticked, scheduled)
        c.call("fmi3EnterStepMode", f.enterStepMode)

    def _instant(self, t: float, ticked: list[FmuPort], scheduled: list[FmuPort]) -> None:
        self.event(t, ticked, scheduled)
        for _ in range(MAX_ITERATIONS):
            due = self.due_at(t)
            if not due:
                break
            self.event(t, [], due)

    def event(self, t: float, ticked: list[FmuPort], scheduled: list[FmuPort]) -> None:
        """One event at t [s], the FMU in event mode: activate the `ticked` input clocks and the
        `scheduled` ones, set the clocked inputs of the ticked ones, get the output clocks and
        what they clock, update the discrete states until they settle, read the new intervals."""
        c, f = self.comp, self.comp.instance
        d = c.values
        c.now = t
        activate = [*ticked, *scheduled]
        if activate:
            c.call(f"fmi3SetClock of {', '.join(p.name for p in activate)}", f.setClock,
                    [p.vrs[0] for p in activate], [True] * len(activate))
        vrs = {p.vrs[0] for p in ticked}
        clocked = [p for p in self.clocked_in if vrs & set(p.clocked_by)]
        if clocked:
            c.write(clocked)
        active = {p.vrs[0] for p in activate}
        if self.out_clocks:
            values = c.call(f"fmi3GetClock of {', '.join(p.name for p in self.out_clocks)}",
                             f.getClock, [p.vrs[0] for p in self.out_clocks])
            active.update(p.vrs[0] for p, v in zip(self.out_clocks, values, strict=True) if v)
        for p in self.out_clocks + scheduled:
            if p.vrs[0] in active:
                d[p.name] = True
                self.ticks.append((t, p.name))
        self._read([p for p in self.clocked_out if active & set(p.clocked_by)], t)
        due = self.due()
        for p in scheduled:
            period = self._periodic[p.name][0] if p.name in self._periodic else \
                self._period.get(p.name)
            if p.clock != "countdown" and period:
                due[p.name] = due[p.name] + period
            else:
                due.pop(p.name, None)
        self._set_due(due)
        self.settle(t)

    def settle(self, t: float) -> None:
        """fmi3UpdateDiscreteStates until the discrete states settle, then the intervals."""
        c, f = self.comp, self.comp.instance
        for _ in range(MAX_ITERATIONS):
            need, terminate, _, _, defined, next_time = c.call("fmi3UpdateDiscreteStates",
                                                                f.updateDiscreteStates)
            if terminate:
                raise c.terminated(t, "(fmi3UpdateDiscreteStates terminateSimulation)")
            if not need:
                break
        else:
            raise FmuError(c.name, t, f"FMU '{c.path.name}': its discrete states did not settle "
                           f"in {MAX_ITERATIONS} calls of fmi3UpdateDiscreteStates (an event "
                           f"loop). Fix: see the FMU's log.", c.log.tail())
        c.time_event = float(next_time) if defined and next_time > t else math.inf
        self._intervals(t)

    def start(self, t: float) -> None:
        """The event that ends initialization (eventModeUsed): the clocks and clocked outputs
        as they are at t [s]; a periodic clock with a constant interval ticks first at t plus
        its shift, then every interval."""
        self._set_due({name: t + shift for name, (_, shift) in self._periodic.items()})
        self._instant(t, [], self.due_at(t))

    def _intervals(self, t: float) -> None:
        """The next tick of each scheduled clock whose interval the FMU says changed: a
        countdown one after that interval, a periodic one (fixed, tunable, changing) at its
        shift the first time, then every interval from this tick."""
        asked = [p for p in self.scheduled if p.name not in self._periodic]
        if not asked:
            return
        c, f = self.comp, self.comp.instance
        n = len(asked)
        vrs = (ctypes.c_uint32 * n)(*(p.vrs[0] for p in asked))
        intervals = (ctypes.c_double * n)()
        qualifiers = (ctypes.c_int * n)()
        c.call(f"fmi3GetIntervalDecimal of {', '.join(p.name for p in asked)}",
                f.getIntervalDecimal, vrs, intervals, qualifiers)
        due = self.due()
        for p, interval, qualifier in zip(asked, intervals, qualifiers, strict=True):
            if qualifier == _QUALIFIER_CHANGED:
                if not interval > 0 and p.clock != "countdown":
                    raise FmuError(c.name, t, f"FMU '{c.path.name}': clock '{p.name}' has "
                                   f"interval {interval!r} s; a periodic clock needs a positive "
                                   f"one. Fix: see the FMU's log.", c.log.tail())
                if p.clock == "countdown":
                    due[p.name] = t + max(0.0, interval)
                else:
                    due[p.name] = t + (self._shift[p.name] if p.name not in self._period
                                       else interval)
                    self._period[p.name] = interval
        self._set_due(due)

    def _read(self, ports: list[FmuPort], t: float) -> None:
        """Get clocked outputs that ticked; a bus terminal's data appends within one step."""
        if not ports:
            return
        c = self.comp
        d = c.values
        before = {p.name: d[p.name] for p in ports}
        for getter, vrs, count, names, _ in c.plan(ports, 0):
            values = c.call(f"{getter.__name__} of {', '.join(n for n, _, _ in names)}",
                             getter, vrs, count)
            k = 0
            for name, scalar, n in names:
                value = values[k] if scalar else tuple(values[k:k + n])
                if isinstance(value, bytes) or value is None:
                    value = value or b""
                    c.check_bus_data(name, value, t)
                    if name in c.bus_data:
                        value = before[name].then(t, value) if name in self._fresh else \
                            TickedData(value, ((t, 0),))
                d[name] = value
                self._fresh.add(name)
                k += n


def _tol(t: float) -> float:
    """Times closer than this [s] are one instant."""
    return 1e-9 * max(1.0, abs(t))
