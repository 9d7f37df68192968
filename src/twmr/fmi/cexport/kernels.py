"""Which C kernel implements each exportable kind, and what is fixed at export.

Real parameters become FMI parameters (tunable when the kernel reads them at every step, else
fixed); the choices given by text or flags (a slip profile, a trajectory shape, a motor mode, a
controller's drive side, saturation and anti-windup) and the sizes of a state-space block are
compiled into the FMU (`config.h`), so each FMU is one variant.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import CosimError

#: slip profile codes (components/_model.py: HELD, PAPER, NO_SLIP, CONSTANT, STEP, MUD)
_PROFILES = {"paper": 1, "none": 2, "constant": 3, "step": 4, "mud": 5}
_SHAPES = {"paper1": 0, "circle": 1, "lemniscate": 2}
_GAINS = ("lam", "vartheta", "k", "lookahead", "eps_singular", "phi", "torque_limit")


@dataclass(frozen=True)
class Kernel:
    """C source of a kind's kernel; `options(comp)` gives the #defines of the variant (raising
    CosimError for what the C export does not support); `work(comp)` the number of work values;
    `hidden` the parameters not exported (not used by any exported variant)."""

    source: str
    tunable: frozenset[str] = frozenset()
    options: Callable[[Component], dict[str, int]] = field(default=lambda comp: {})
    work: Callable[[Component], int] = field(default=lambda comp: 1)
    hidden: frozenset[str] = frozenset()


def _refuse(comp: Component, what: str, fix: str) -> CosimError:
    return CosimError(f"export {comp.kind}: {what} has no C kernel. Fix: {fix}, or export "
                      f"with --python (a pythonfmu FMU that needs twmr-cosim where it runs).")


def _choice(comp: Component, name: str, codes: dict[str, int], extra: str = "") -> int:
    value = comp.get(name)
    if value not in codes:
        raise _refuse(comp, f"{name} '{value}'", f"use {name} {' | '.join(codes)}{extra}")
    return codes[value]


def _slip(comp: Component) -> dict[str, int]:
    return {"PROFILE": _choice(comp, "profile", _PROFILES)}


def _shape(comp: Component) -> dict[str, int]:
    return {"SHAPE": _choice(comp, "shape", _SHAPES)}


def _tracking(comp: Component) -> dict[str, int]:
    options = {"DRIVE": _choice(comp, "drive", {"auto": 0, "forward": 1, "backward": 2}),
               "SAT_SCALE": _choice(comp, "saturation", {"clip": 0, "scale": 1})}
    if comp.kind == "asmc":
        options.update(ADAPTIVE=1, HOLD_SATURATED=int(bool(comp.get("hold_saturated"))))
    return options


def _motor(comp: Component) -> dict[str, int]:
    return {"MODE_DC": _choice(comp, "mode", {"ideal": 0, "dc": 1})}


def state_space_size(comp: Component) -> int:
    """Number of states n of a `state_space` block, its matrices checked (A n*n, C n, x0 n or
    empty: zeros)."""
    n = len(comp.get("B"))
    sizes = {"A": n * n, "C": n, "x0": n}
    for name, size in sizes.items():
        got = len(comp.get(name))
        if got != size and not (name == "x0" and got == 0):
            raise CosimError(f"export state_space: {name} has {got} values but B has {n} "
                             f"(expected {size}). Fix: give A as n*n values row by row, B, C "
                             f"and x0 as n values each.")
    if n == 0:
        raise CosimError("export state_space: B is empty. Fix: give at least one state.")
    return n


def _ss_options(comp: Component) -> dict[str, int]:
    return {"N_SS": state_space_size(comp)}


def _ss_work(comp: Component) -> int:
    n = state_space_size(comp)
    return n * n + 2 * n + 1


KERNELS: dict[str, Kernel] = {
    "twmr_plant": Kernel("plant.c", work=lambda comp: 8),
    "slip_disturbance": Kernel("slip.c", options=_slip, hidden=frozenset({"bandwidth", "seed"})),
    "trajectory": Kernel("trajectory.c", frozenset({"radius", "omega", "phase", "center"}),
                         options=_shape, hidden=frozenset({"waypoints", "times"})),
    "asmc": Kernel("tracking.c", frozenset((*_GAINS, "eta", "d_hat_limit")), options=_tracking,
                   work=lambda comp: 4),
    "smc": Kernel("tracking.c", frozenset(_GAINS), options=_tracking, work=lambda comp: 4),
    "motor_driver": Kernel("motor.c", options=_motor, work=lambda comp: 9),
    "constant": Kernel("constant.c"),
    "sine": Kernel("sine.c", frozenset({"amplitude", "frequency", "phase", "offset"})),
    "step": Kernel("step.c", frozenset({"height", "time", "offset"})),
    "gain": Kernel("gain.c", frozenset({"k"})),
    "sum": Kernel("sum.c", frozenset({"k1", "k2"})),
    "integrator": Kernel("integrator.c", frozenset({"k"})),
    "state_space": Kernel("state_space.c", options=_ss_options, work=_ss_work),
    "delay": Kernel("delay.c"),
}


def kernel_of(kind: str) -> Kernel:
    """The C kernel of `kind`; CosimError naming the kinds that have one."""
    if kind not in KERNELS:
        raise CosimError(f"kind '{kind}' has no C kernel for a standalone FMU; these have: "
                         f"{', '.join(sorted(KERNELS))}. Fix: export one of them, or use "
                         f"--python for a component of your own (a pythonfmu FMU).")
    return KERNELS[kind]


def options_text(comp: Component, kernel: Kernel) -> dict[str, Any]:
    """The text and integer parameters the FMU is compiled with (for its description)."""
    return {n: comp.get(n) for n, v in comp.parameters.items()
            if v.type != "Real" and n not in kernel.hidden}
