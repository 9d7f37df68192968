"""The CAN protocols' host sides in C, for a controller FMU on an FMI-LS-BUS CAN terminal
(`twmr export asmc --fmi 3 --can odrive|cia402`, `twmr.fmi.cexport.busnode`): each C file in
c/ beside the Python it twins (c/odrive.c: `protocol`; c/cia402.c: `cia402` and the PDO layout of
`cia402_link`), held byte-equal to it by tests/property/test_can_codec_c.py. Their parameters are
the `can_drive` block's, with its defaults and units.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from twmr.core.errors import CosimError
from twmr.core.port import Parameter
from twmr.fmi.cexport.busnode import CNode
from twmr.hw import cia402
from twmr.hw import protocol as p
from twmr.hw.drive import CanMotorDrive
from twmr.hw.link import option_parameters

C = Path(__file__).parent / "c"


def _drive_parameters(options: type, *names: str) -> dict[str, Parameter]:
    """The `can_drive` block's parameters `names`, its own or those of the protocol's
    `options`."""
    own = option_parameters(options)
    out = {}
    for name in names:
        var = replace(own[name] if name in own else getattr(CanMotorDrive, name))
        var.name = name
        out[name] = var
    return out


def _odrive_options(texts: Mapping[str, str]) -> dict[str, int]:
    """ODRIVE_LINE: 5 or 6, the firmware line."""
    try:
        line = p.firmware_line(texts["firmware"])
    except ValueError as err:
        raise CosimError(f"export --can odrive: drive.firmware: {err}. Fix: give the firmware the "
                         f"drives run, e.g. --set drive.firmware=0.6.10.") from None
    return {"ODRIVE_LINE": int(line.split(".")[1])}


ODRIVE = CNode(source=C / "odrive_node.c", codec=(C / "odrive.c", C / "odrive.h"),
               parameters=_drive_parameters(p.OdriveOptions, "node_ids", "gear", "torque_limit",
                                            "speed_limit", "torque_constant",
                                            "watchdog_periods"),
               texts={"firmware": p.OdriveOptions().firmware}, options=_odrive_options,
               state=2)
CIA402 = CNode(source=C / "cia402_node.c", codec=(C / "cia402.c", C / "cia402.h"),
               parameters=_drive_parameters(cia402.Cia402Options, "node_ids", "gear",
                                            "torque_limit", "rated_torque", "watchdog_periods"),
               state=6)
