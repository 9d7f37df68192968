"""What the C twins of the paper's blocks share (c/<block>.c beside them; each block declares its
own twin, `c_twin`, for `twmr export KIND`: a standalone C FMU).

The codes the Python and the C side share are the Python constants, #defined into each FMU's
config.h: the slip profile codes of `_model` (SLIP_PAPER, ...; the slip block writes them into its
`model` descriptor and the plant reads them), the index of each field of that descriptor (D_CODE,
D_SLIP_GAIN, ...: the fields of `_model.SlipProfile`, in its order).
"""
from __future__ import annotations

from pathlib import Path

from twmr import blocks
from twmr.components import _model
from twmr.core.ctwin import Choice

C = Path(__file__).parent / "c"

SLIP_CODES = {f"SLIP_{name}": getattr(_model, name)
              for name in ("HELD", "PAPER", "NO_SLIP", "CONSTANT", "STEP", "MUD")}
#: the profile descriptor's fields (`_model.SlipProfile`), name -> index
SLIP_FIELDS = {f"D_{name.upper()}": i for i, name in enumerate(_model.SlipProfile._fields)}
SLIP_DEFINES = {**SLIP_CODES, **SLIP_FIELDS}
#: the profiles the C twin evaluates (`random` draws from numpy's generator: Python only)
PROFILES = {"paper": _model.PAPER, "none": _model.NO_SLIP, "constant": _model.CONSTANT,
            "step": _model.STEP, "mud": _model.MUD}
GAINS = ("lam", "vartheta", "k", "lookahead", "eps_singular", "phi", "torque_limit")
TRACKING = {"drive": Choice("DRIVE", {"auto": 0, "forward": 1, "backward": 2}),
            "saturation": Choice("SAT_SCALE", {"clip": 0, "scale": 1})}
DRIVES = {"DRIVE_FORWARD": 1, "DRIVE_BACKWARD": 2}

INERTIA, SLIP_PROFILE = C / "inertia.h", C / "slip_profile.h"
LOOK_AHEAD = C / "look_ahead.h"  # the tracking laws' error model
SAMPLED = C / "sampled.h"
#: the blocks' one random generator (twmr.blocks.philox)
PHILOX = Path(blocks.__file__).parent / "c" / "philox.h"
