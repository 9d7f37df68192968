"""The C twins of the paper's blocks (c/<block>.c beside them), registered in the entry-point
group `twmr.c_kernels` for `twmr export KIND` (standalone C FMUs).

The codes the Python and the C side share are the Python constants, #defined into each FMU's
config.h: the slip profile codes of `_model` (SLIP_PAPER, ...; the slip block writes them into its
`model` descriptor and the plant reads them), the index of each field of that descriptor (D_CODE,
D_SLIP_GAIN, ...: the fields of `_model.SlipProfile`, in its order) and the trajectory shapes of
`trajectory` (SHAPE_*).
"""
from __future__ import annotations

from pathlib import Path

from twmr.blocks.ctwins import C as BLOCKS_C
from twmr.components import _model, trajectory
from twmr.fmi.cexport.twin import Choice, CTwin

C = Path(__file__).parent / "c"

SLIP_CODES = {f"SLIP_{name}": getattr(_model, name)
              for name in ("HELD", "PAPER", "NO_SLIP", "CONSTANT", "STEP", "MUD")}
#: the profile descriptor's fields (`_model.SlipProfile`), name -> index
SLIP_FIELDS = {f"D_{name.upper()}": i for i, name in enumerate(_model.SlipProfile._fields)}
_SLIP_DEFINES = {**SLIP_CODES, **SLIP_FIELDS}
#: the profiles the C twin evaluates (`random` draws from numpy's generator: Python only)
PROFILES = {"paper": _model.PAPER, "none": _model.NO_SLIP, "constant": _model.CONSTANT,
            "step": _model.STEP, "mud": _model.MUD}
#: the analytic shapes (`waypoints` is a scipy spline: Python only)
SHAPES = {"paper1": trajectory.PAPER1, "circle": trajectory.CIRCLE,
          "lemniscate": trajectory.LEMNISCATE}
_GAINS = ("lam", "vartheta", "k", "lookahead", "eps_singular", "phi", "torque_limit")
_TRACKING = {"drive": Choice("DRIVE", {"auto": 0, "forward": 1, "backward": 2}),
             "saturation": Choice("SAT_SCALE", {"clip": 0, "scale": 1})}
_DRIVES = {"DRIVE_FORWARD": 1, "DRIVE_BACKWARD": 2}

INERTIA, SLIP_PROFILE = C / "inertia.h", C / "slip_profile.h"
SAMPLED = C / "sampled.h"
#: the blocks' one random generator (twmr.blocks.philox)
PHILOX = BLOCKS_C / "philox.h"

PLANT = CTwin(C / "plant.c", headers=(INERTIA, SLIP_PROFILE), defines=_SLIP_DEFINES,
              work=lambda comp: 8)
SLIP = CTwin(C / "slip.c", headers=(SLIP_PROFILE,), defines=_SLIP_DEFINES,
             choices={"profile": Choice("PROFILE", PROFILES)},
             hidden=frozenset({"bandwidth", "seed"}))
TRAJECTORY = CTwin(C / "trajectory.c", tunable=frozenset({"radius", "omega", "phase", "center"}),
                   choices={"shape": Choice("SHAPE", {k: int(v) for k, v in SHAPES.items()})},
                   defines={f"SHAPE_{k.upper()}": int(v) for k, v in SHAPES.items()},
                   hidden=frozenset({"waypoints", "times"}))
ASMC = CTwin(C / "tracking.c", headers=(INERTIA,),
             tunable=frozenset((*_GAINS, "eta", "d_hat_limit")),
             choices={**_TRACKING, "hold_saturated": Choice("HOLD_SATURATED", {True: 1, False: 0})},
             defines={**_DRIVES, "ADAPTIVE": 1}, work=lambda comp: 4)
SMC = CTwin(C / "tracking.c", headers=(INERTIA,), tunable=frozenset(_GAINS), choices=_TRACKING,
            defines=_DRIVES, work=lambda comp: 4)
MOTOR = CTwin(C / "motor.c", choices={"mode": Choice("MODE_DC", {"ideal": 0, "dc": 1})},
              work=lambda comp: 9)
ENCODER = CTwin(C / "encoder.c", headers=(SAMPLED,), tunable=frozenset({"sample_period"}),
                work=lambda comp: 3)
IMU = CTwin(C / "imu.c", headers=(SAMPLED, PHILOX),
            tunable=frozenset({"bias", "noise_std", "sample_period"}), work=lambda comp: 3)
