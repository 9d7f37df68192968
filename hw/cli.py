"""The `twmr emulate-drive` and `twmr replay` subcommands, registered through the `twmr.commands`
entry point: emulated CAN drives on a python-can bus, and a run's frame log decoded or replayed."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError


def emulate_drive(args: argparse.Namespace) -> int:
    """Emulated drives (ODrive or CiA 402) answering on a python-can bus until Ctrl-C."""
    if not args.node:
        args.node = [0, 1] if args.protocol == "odrive" else [1, 2]
    import can

    from twmr.hw.bus import bus_options, describe
    from twmr.hw.safety import node_id_problem

    problem = node_id_problem(args.protocol, args.node)
    if problem:
        raise CosimError(f"emulate-drive: {problem}. Fix: give --node ids the protocol can "
                         f"address (ODrive 0..63, CANopen 1..126), each once.")
    if args.eds and args.protocol != "cia402":
        raise CosimError(f"emulate-drive: --eds {args.eds} is for CiA 402 drives. Fix: add "
                         f"--protocol cia402, or leave --eds out.")
    if args.eds and not Path(args.eds).is_file():
        raise CosimError(f"emulate-drive: the EDS/DCF {args.eds} does not exist. Fix: give the "
                         f"drive's description file.")

    try:
        options = bus_options(args.interface, args.channel, args.bitrate, args.can_config or "",
                              args.can_context)
        if args.protocol == "odrive":
            from twmr.hw.emulator import OdriveEmulator

            emu: Any = OdriveEmulator(tuple(args.node), options, args.firmware, args.gear,
                                      encoder_period=args.encoder_period,
                                      torque_constant=args.torque_constant)
        else:
            from importlib import resources

            from twmr.hw.cia402_emulator import Cia402Emulator

            eds = args.eds or str(resources.files("twmr.hw").joinpath(
                "data", "maxon_epos4_module_50-5.eds"))
            emu = Cia402Emulator(tuple(args.node), eds, options, args.gear)
    except (OSError, ValueError, ImportError, can.CanError) as err:
        raise CosimError(f"emulate-drive: cannot start the emulated drives ({err}). Fix: check "
                         f"--interface/--channel, --can-config and --eds.") from None
    print(f"emulating {args.protocol} drives {args.node} on {describe(options)}; Ctrl-C stops",
          file=sys.stderr)
    try:
        while True:
            time.sleep(1.0)
            print(", ".join(f"{n}: {_axis_text(a)}" for n, a in emu.axes.items()),
                  file=sys.stderr)
    finally:
        emu.close()


def replay(args: argparse.Namespace) -> int:
    """A run's frame log decoded to SI values (CSV), or played onto a bus."""
    from twmr.hw.bus import bus_options, describe
    from twmr.hw.replay import Decoder, decode_log, play

    log = Path(args.log)
    if not log.is_file():
        raise CosimError(f"{log}: no such frame log. Fix: give the <name>_frames.blf (or .asc) "
                         f"that `twmr run` wrote beside the results.")
    if args.play:
        options = bus_options(args.interface, args.channel, args.bitrate, args.can_config or "",
                              args.can_context)
        n = play(log, options, paced=not args.fast)
        print(f"{n} frames of {log} sent on {describe(options)}", file=sys.stderr)
        return 0
    decoder = Decoder(args.protocol, args.firmware, args.gear, args.rated_torque)
    try:
        decoded = decode_log(log, decoder)
    except Exception as err:  # noqa: BLE001 - python-can's readers raise many kinds
        raise CosimError(f"{log}: cannot read it as a frame log ({type(err).__name__}: {err}). "
                         f"Fix: give the .blf or .asc file `twmr run` wrote beside the results."
                         ) from None
    if not decoded:
        raise CosimError(f"{log}: no {args.protocol} frames found in it. Fix: check --protocol "
                         f"(odrive or cia402) and that this is a bench run's frame log.")
    out = open(args.out, "w") if args.out else sys.stdout  # noqa: SIM115 - closed below
    try:
        out.write("time_s,direction,node,signal,value\n")
        for d in decoded:
            out.write(f"{d.time:.6f},{d.direction},{'' if d.node is None else d.node},"
                      f"{d.signal},{d.value:.9g}\n")
    finally:
        if out is not sys.stdout:
            out.close()
    return 0


def _axis_text(axis: Any) -> str:
    state = getattr(axis.state, "value", axis.state)
    error = f" err 0x{axis.error:x}" if getattr(axis, "error", 0) else ""
    return f"state {state}{error} torque {axis.torque:.3g} N.m"


def register(subparsers: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    """Add `emulate-drive` and `replay` to the command line."""
    em = subparsers.add_parser("emulate-drive", parents=[common],
                               help="emulated drives on a CAN bus (no hardware)")
    em.add_argument("--protocol", choices=("odrive", "cia402"), default="odrive")
    em.add_argument("--interface", default="virtual")
    em.add_argument("--channel", default="twmr")
    em.add_argument("--bitrate", type=int, default=1_000_000)
    em.add_argument("--can-config", help="python-can config file (replaces interface/channel)")
    em.add_argument("--can-context", default="default", help="section of --can-config")
    em.add_argument("--firmware", default="0.6.10", help="ODrive firmware (0.5.x | 0.6.x)")
    em.add_argument("--encoder-period", type=float, default=1e-3,
                    help="ODrive: cyclic encoder estimates period [s] (0: only on request)")
    em.add_argument("--torque-constant", type=float, default=0.04, help="ODrive: N.m/A")
    em.add_argument("--eds", help="CiA 402: EDS/DCF of the drives (default: shipped EPOS4)")
    em.add_argument("--gear", type=float, default=1.0)
    em.add_argument("--node", type=int, action="append", default=None,
                    help="axis node id (repeatable; default 0 and 1, CiA 402: 1 and 2)")
    em.set_defaults(fn=emulate_drive)
    rp = subparsers.add_parser("replay", parents=[common],
                               help="decode a run's CAN frame log to CSV, or play it onto a bus")
    rp.add_argument("log", help="<name>_frames.blf or .asc written beside the results")
    rp.add_argument("--protocol", choices=("odrive", "cia402"), default="odrive")
    rp.add_argument("--firmware", default="0.6.10", help="ODrive firmware (0.5.x | 0.6.x)")
    rp.add_argument("--gear", type=float, default=1.0, help="motor turns per wheel turn")
    rp.add_argument("--rated-torque", type=int, default=1000, help="CiA 402 0x6076 [mN.m]")
    rp.add_argument("--out", help="CSV file (default: standard output)")
    rp.add_argument("--play", action="store_true", help="send the frames onto a bus instead")
    rp.add_argument("--fast", action="store_true", help="with --play: no original timing")
    rp.add_argument("--interface", default="virtual")
    rp.add_argument("--channel", default="twmr")
    rp.add_argument("--bitrate", type=int, default=1_000_000)
    rp.add_argument("--can-config", help="python-can config file (replaces interface/channel)")
    rp.add_argument("--can-context", default="default")
    rp.set_defaults(fn=replay)
