"""`Integrator`: a model-exchange FMU (FMI 2.0 or 3.0) integrated over a communication step, with
its events, as the FMI standard's importer algorithm does it.

- **Solvers**: ``cvode`` (default; SUNDIALS CVODE, BDF with a dense Newton solver, as bundled
  with fmpy; relative tolerance `rtol`, absolute `atol` per state or rtol × the state's nominal,
  largest step `max_step` [s]) and ``rk4`` (fixed step `solver_step` [s], chosen explicitly).
- **State events**: CVODE's root finding on the event indicators; with RK4 a sign change within a
  step is located by bisection to 1e-12 of the step. The state handed to the FMU at an event is
  just past the crossing, as the standard requires.
- **Time events** (`nextEventTime`) end an integration exactly at that time; **step events**
  (`completedIntegratorStep` asking for event mode) are handled after the step.
- **Event iteration** (`fmi2NewDiscreteStates` / `fmi3UpdateDiscreteStates`) until no new
  discrete states are needed; the solver restarts after every event.
- **Discrete inputs** are set only in event mode: a change of one is an event at that time.
- **Held events**: with `hold` set (by a master that locates events, `twmr.master.adaptive`), a
  state event found at the very end of an integration is left for `handle_held`, so the
  importer sees the values just before it; `state_event` is the time of the first state event of
  the last `advance`. CVODE starts every integration with the same first step (`INIT_STEP`,
  not chosen from the end time), so integrations from one restart to different end times take the
  same internal steps and find a crossing at the same time: a step retried up to a located event
  finds it again at its end. With `stop_inside` set, a state event inside the integration (to
  that tolerance from its ends) ends `advance` there, unhandled.
- **Saves**: CVODE goes on with its history across a `save` (a restart costs it many small
  first-order steps) and restarts at a `restore`; `continued` says that the integration since
  the last save did not start from a restart there (at the save or after it, as when an input
  changed).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from ctypes import POINTER, c_double
from typing import Any

import numpy as np

SOLVERS = ("cvode", "rk4")
#: CVODE's first step after every restart [s] (at most `max_step`)
INIT_STEP = 1e-6


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-14)


class Terminated(Exception):
    """The FMU asked to terminate the simulation (terminateSimulation)."""


class _NoInput:
    """fmpy's solvers apply input signals at each evaluation; inputs here are held, set before."""

    @staticmethod
    def apply(*args: Any, **kwargs: Any) -> None:
        return None


class Integrator:
    """Drives one model-exchange instance (fmpy's FMU2Model or FMU3Model, after
    exitInitializationMode) through event iteration, continuous-time integration and events."""

    def __init__(self, fmu: Any, md: Any, fmi3: bool, solver: str, rtol: float,
                 atol: float | None, max_step: float, solver_step: float,
                 call: Callable[..., Any]):
        self.fmu, self.md, self.fmi3 = fmu, md, fmi3
        self.solver_name, self.rtol, self.atol = solver, rtol, atol
        self.max_step, self.solver_step = max_step, solver_step
        self.call = call  # call(what, fn, *args): the component's FMI call wrapper
        self.next_event: float | None = None
        self.events = 0
        self.hold = False
        #: a tolerance [s]: a state event met more than this after the start of `advance` and
        #: before its end time ends it there, unhandled; None: never
        self.stop_inside: float | None = None
        self.held = False
        self.state_event: float | None = None
        self._solver: Any = None
        #: the time of the solver's last restart while it has not integrated since (else None)
        self._fresh_at: float | None = None
        #: the integration since the last `save` went on from the solver's history at the save
        self.continued = False
        self._saved = False  # a save since the last integration
        # fmpy reads FMI 3.0's needsCompletedIntegratorStep and FMI 2.0's
        # completedIntegratorStepNotNeeded into this one flag
        self.completed_needed = bool(md.modelExchange.needsCompletedIntegratorStep)

    # -- event iteration ---------------------------------------------------------------------
    def _iterate(self, t: float) -> None:
        """newDiscreteStates / updateDiscreteStates until converged; keeps nextEventTime."""
        f = self.fmu
        for _ in range(10_000):
            if self.fmi3:
                need, terminate, _, _, defined, nxt = self.call(
                    "fmi3UpdateDiscreteStates", f.updateDiscreteStates)
            else:
                need, terminate, _, _, defined, nxt = self.call(
                    "fmi2NewDiscreteStates", f.newDiscreteStates)
            if terminate:
                raise Terminated(t)
            self.next_event = float(nxt) if defined else None
            if not need:
                return
        raise RuntimeError("event iteration did not converge in 10,000 iterations")

    def start(self, t: float) -> None:
        """After exitInitializationMode: event iteration, continuous-time mode, solver set up."""
        self._iterate(t)
        self.call("EnterContinuousTimeMode", self.fmu.enterContinuousTimeMode)
        f = self.fmu
        if self.fmi3:
            self.nx = int(self.call("fmi3GetNumberOfContinuousStates",
                                    f.getNumberOfContinuousStates))
            self.nz = int(self.call("fmi3GetNumberOfEventIndicators",
                                    f.getNumberOfEventIndicators))
            self._get_dx = f.getContinuousStateDerivatives
        else:
            self.nx = self.md.numberOfContinuousStates
            self.nz = self.md.numberOfEventIndicators
            self._get_dx = f.getDerivatives
        self.x = np.zeros(max(self.nx, 1))
        self.dx = np.zeros(max(self.nx, 1))
        self.z = np.zeros(max(self.nz, 1))
        self._px = self.x.ctypes.data_as(POINTER(c_double))
        self._pdx = self.dx.ctypes.data_as(POINTER(c_double))
        self._pz = self.z.ctypes.data_as(POINTER(c_double))
        self.t = t
        self._restart(t)

    def _restart(self, t: float) -> None:
        """CVODE starts afresh at t (RK4 keeps no history)."""
        self._fresh_at = t
        if self.solver_name != "cvode":
            return
        if self._solver is None:
            self._solver = self._cvode(t)
        else:
            self._solver.reset(t)

    def _cvode(self, t: float) -> Any:
        from fmpy.sundials import CVodeSolver

        f = self.fmu
        nominals = f.getNominalsOfContinuousStates
        solver = CVodeSolver(nx=self.nx, nz=self.nz, get_x=f.getContinuousStates,
                             set_x=f.setContinuousStates, get_dx=self._get_dx,
                             get_z=f.getEventIndicators, get_nominals=nominals,
                             set_time=f.setTime, input=_NoInput(), startTime=t,
                             maxStep=self.max_step if self.max_step > 0 else math.inf,
                             relativeTolerance=self.rtol, maxNumSteps=100_000)
        if self.atol is not None and self.nx:
            from fmpy.sundials.cvode import CVodeSVtolerances

            solver.npabstol[:] = self.atol
            CVodeSVtolerances(solver.cvode_mem, self.rtol, solver.abstol)
        _init_step(solver.cvode_mem, min(INIT_STEP, self.max_step) if self.max_step > 0
                   else INIT_STEP)
        return solver

    def save(self) -> tuple[float, float | None, int]:
        """What restoring the FMU's state needs from here: the time [s], the next time event and
        the count of events so far. The solver goes on with its history (`continued`, unless it
        restarts here before integrating); a restore restarts it."""
        self.continued, self._saved = False, True
        return self.t, self.next_event, self.events

    def restore(self, saved: tuple[float, float | None, int]) -> None:
        """Back to `saved` (the FMU's own state set just before); the solver restarts there, and
        the events of the steps undone are no longer counted (nor a held one)."""
        self.t, self.next_event, self.events = saved
        self.held, self.state_event = False, None
        self._restart(self.t)
        self.continued = False

    def handle_held(self) -> bool:
        """The state event held at the end of the last `advance`, handled now; False: none."""
        if not self.held:
            return False
        self.event(self.t)
        return True

    def restart(self) -> None:
        """Inputs changed (held piecewise constant): the solver restarts from the present."""
        self._restart(self.t)

    def event(self, t: float, set_discrete: Callable[[], None] | None = None) -> None:
        """An event at t: event mode, `set_discrete()` (discrete inputs), iteration, back to
        continuous time; the solver restarts."""
        f = self.fmu
        self.held = False
        self.call("EnterEventMode", f.enterEventMode)
        if set_discrete is not None:
            set_discrete()
        self._iterate(t)
        self.call("EnterContinuousTimeMode", f.enterContinuousTimeMode)
        self.events += 1
        self._restart(t)

    # -- integration -------------------------------------------------------------------------
    def advance(self, t_end: float) -> None:
        """Integrate from the current time to t_end [s], handling every event on the way."""
        f = self.fmu
        guard = 0
        t_start = self.t
        self.state_event = None
        self.handle_held()  # not handled by the master: before going on
        if self._saved:
            self.continued = self.solver_name == "cvode" and self._fresh_at != self.t
            self._saved = False
        if not _close(self.t, t_end):
            self._fresh_at = None
        while not _close(self.t, t_end) and self.t < t_end:
            guard += 1
            if guard > 1_000_000:
                raise RuntimeError(f"more than a million events before t = {t_end}")
            target = t_end
            time_event = False
            if self.next_event is not None and self.next_event <= t_end + 1e-12 * abs(t_end):
                if self.next_event <= self.t or _close(self.next_event, self.t):
                    self.event(self.t)  # due now (set at the previous event)
                    continue
                target, time_event = self.next_event, True
            if self.solver_name == "cvode":
                state_event, t_reached = self._cvode_step(target)
            else:
                state_event, t_reached = self._rk4_step(target)
            if _close(t_reached, t_end):
                t_reached = t_end
            self.t = t_reached
            self.call("SetTime", f.setTime, t_reached)
            step_event = False
            if self.completed_needed:
                step_event, terminate = self.call("CompletedIntegratorStep",
                                                  f.completedIntegratorStep)
                if terminate:
                    raise Terminated(t_reached)
            time_event = time_event and _close(t_reached, target)
            if state_event and self.state_event is None:
                self.state_event = t_reached
                tol = self.stop_inside
                if tol is not None and t_start + tol < t_reached < t_end - tol:
                    return  # the master takes the step again to end here
            if state_event and self.hold and t_reached == t_end and not (time_event or
                                                                         step_event):
                self.held = True
            elif state_event or time_event or step_event:
                self.event(t_reached)

    def _cvode_step(self, target: float) -> tuple[bool, float]:
        state_event, _, t_reached = self.call("CVODE", self._solver.step, self.t, target)
        return bool(state_event) and self.nz > 0, float(t_reached)

    def _derivatives(self, t: float, x: np.ndarray) -> np.ndarray:
        self.x[:self.nx] = x
        self.fmu.setTime(t)
        self.fmu.setContinuousStates(self._px, self.nx)
        self._get_dx(self._pdx, self.nx)
        return self.dx[:self.nx].copy()

    def _rk4(self, t: float, x: np.ndarray, h: float) -> np.ndarray:
        if not self.nx:
            return x
        k1 = self._derivatives(t, x)
        k2 = self._derivatives(t + h / 2, x + h / 2 * k1)
        k3 = self._derivatives(t + h / 2, x + h / 2 * k2)
        k4 = self._derivatives(t + h, x + h * k3)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def _indicators(self, t: float, x: np.ndarray) -> np.ndarray:
        self.x[:self.nx] = x
        self.fmu.setTime(t)
        if self.nx:
            self.fmu.setContinuousStates(self._px, self.nx)
        self.fmu.getEventIndicators(self._pz, self.nz)
        return self.z[:self.nz].copy()

    @staticmethod
    def _crossed(z0: np.ndarray, z1: np.ndarray) -> bool:
        return bool(np.any(((z0 > 0) & (z1 <= 0)) | ((z0 < 0) & (z1 >= 0))))

    def _rk4_step(self, target: float) -> tuple[bool, float]:
        """RK4 steps of at most `solver_step` to `target`; stops just past the first crossing of
        an event indicator, located by bisection."""
        f = self.fmu
        x = np.zeros(self.nx)
        if self.nx:
            f.getContinuousStates(self._px, self.nx)
            x = self.x[:self.nx].copy()
        z0 = self._indicators(self.t, x) if self.nz else None
        t = self.t
        n = max(1, math.ceil((target - t) / self.solver_step - 1e-9))
        hs = (target - t) / n
        for k in range(n):
            tk = t + k * hs
            t_next = target if k == n - 1 else t + (k + 1) * hs
            x1 = self._rk4(tk, x, t_next - tk)
            if z0 is not None:
                z1 = self._indicators(t_next, x1)
                if self._crossed(z0, z1):
                    lo, hi, x_hi = 0.0, t_next - tk, x1
                    while hi - lo > 1e-12 * max(hs, 1e-300) and hi - lo > 1e-15:
                        mid = (lo + hi) / 2
                        xm = self._rk4(tk, x, mid)
                        if self._crossed(z0, self._indicators(tk + mid, xm)):
                            hi, x_hi = mid, xm
                        else:
                            lo = mid
                    self._set_state(tk + hi, x_hi)
                    return True, tk + hi
                z0 = z1
            x = x1
        self._set_state(target, x)
        return False, target

    def _set_state(self, t: float, x: np.ndarray) -> None:
        self.fmu.setTime(t)
        if self.nx:
            self.x[:self.nx] = x
            self.fmu.setContinuousStates(self._px, self.nx)

    def close(self) -> None:
        self._solver = None


def _init_step(cvode_mem: Any, h0: float) -> None:
    """CVodeSetInitStep (fmpy declares it but binds it not); it holds across CVodeReInit."""
    from ctypes import c_int, c_void_p

    from fmpy.sundials import cvode

    fn = cvode.sundials_cvode.CVodeSetInitStep
    fn.argtypes, fn.restype = [c_void_p, cvode.sunrealtype], c_int
    if fn(cvode_mem, h0) != 0:
        raise RuntimeError("CVodeSetInitStep failed")
