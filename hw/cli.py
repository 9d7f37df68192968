"""The `twmr emulate-drive` and `twmr replay` subcommands, registered through the `twmr.commands`
entry point: emulated CAN drives on a python-can bus, and a run's frame log decoded or replayed."""
from __future__ import annotations

import argparse
import contextlib
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError
from twmr.hw.link import protocols


def emulate_drive(args: argparse.Namespace) -> int:
    """Emulated drives of any registered protocol answering on a python-can bus until Ctrl-C."""
    import can

    from twmr.hw.bus import bus_options, describe
    from twmr.hw.link import DriveSpec, option_parameters, protocol

    given_options = _from_scenario(args) if args.scenario else {}
    for key, default in DRIVE_DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, default)
    link = protocol(args.protocol)
    nodes = tuple(args.node) if args.node else link.default_nodes
    problem = link.node_problem(nodes)
    if problem:
        raise CosimError(f"emulate-drive: {problem}. Fix: give --node ids the protocol can "
                         f"address ({link.node_range.start}..{link.node_range.stop - 1}), each "
                         f"once.")
    given = {k: v for k, v in given_options.items()
             if k in option_parameters(link.Options) or k in ("torque_limit", "heartbeat_timeout")}
    given.update(protocol_options("emulate-drive", args.protocol, args.option))
    spec = DriveSpec.of(link, args, nodes=nodes, **given)
    for key, what, fix in link.check(spec):
        raise CosimError(f"emulate-drive: {_flag(key, given)}: {what} Fix: {fix}")
    try:
        options = bus_options(args.interface, args.channel, args.bitrate, args.can_config or "",
                              args.can_context)
        emu, _ = link.emulate(spec, options)
    except (OSError, ValueError, ImportError, can.CanError) as err:
        raise CosimError(f"emulate-drive: cannot start the emulated drives ({err}). Fix: check "
                         f"--interface/--channel, --can-config and --option.") from None
    settings = ", ".join(f"{k} {v}" for k, v in vars(spec.options).items())
    print(f"emulating {args.protocol} drives {list(nodes)} on {describe(options)} (gear "
          f"{spec.gear:g}; {settings}); Ctrl-C stops", file=sys.stderr)
    try:
        while True:
            time.sleep(1.0)
            print(", ".join(f"{n}: {_axis_text(a)}" for n, a in emu.axes.items()),
                  file=sys.stderr)
    finally:
        emu.close()


#: emulate-drive's settings when neither the command line nor --scenario gives them
DRIVE_DEFAULTS: dict[str, Any] = {"protocol": "odrive", "interface": "virtual", "channel": "twmr",
                                  "bitrate": 1_000_000, "can_context": "default", "gear": 1.0}
#: a drive block's parameters that are emulate-drive's own flags (parameter -> attribute)
_DRIVE_FLAGS = {"protocol": "protocol", "interface": "interface", "channel": "channel",
                "bitrate": "bitrate", "can_config": "can_config", "can_context": "can_context",
                "gear": "gear", "node_ids": "node"}


def _from_scenario(args: argparse.Namespace) -> dict[str, Any]:
    """The drive block of `--scenario` (`--component`, or its only `can_drive`) as the
    defaults of the flags not given, reading the file as data (nothing of it runs); its
    protocol's options as a dict (what -o gives overrides them). A drive on a `can_bus` block
    takes the bus that block bridges."""
    from twmr.scenario.loaders import load_yaml

    path = Path(args.scenario)
    if not path.is_file():
        raise CosimError(f"emulate-drive: --scenario {path}: no such file. Fix: give the bench "
                         f"scenario whose drives to emulate.")
    spec = load_yaml(path)
    drives = [n for n, c in spec.components.items() if c.kind.value == "can_drive"]
    name = args.component or (drives[0] if len(drives) == 1 else "")
    if not drives:
        raise CosimError(f"emulate-drive: {path} has no kind: can_drive component. Fix: give "
                         f"the bench scenario whose drives to emulate.")
    if name not in drives:
        asked = f" and none named '{args.component}'" if args.component else ""
        raise CosimError(f"emulate-drive: {path} has can_drive components "
                         f"{', '.join(drives)}{asked}. Fix: give --component NAME of one.")
    params = {k: g.value for k, g in spec.components[name].parameters.items()}
    bus = params.pop("bus", None)
    if bus:
        block = spec.components.get(str(bus))
        bridged = {k: g.value for k, g in block.parameters.items()} if block else {}
        if not (bridged.get("interface") or bridged.get("can_config")):
            raise CosimError(f"emulate-drive: drive '{name}' of {path} is on can_bus '{bus}', "
                             f"which bridges no python-can bus another process can join. Fix: "
                             f"give '{bus}' interface/channel or can_config (docs/bench.md, "
                             f"two processes).")
        params.update({k: bridged[k] for k in ("interface", "channel", "bitrate", "can_config",
                                                "can_context") if k in bridged})
    for key, attr in _DRIVE_FLAGS.items():
        if key in params and getattr(args, attr) in (None, []):
            value = params.pop(key)
            setattr(args, attr, [int(n) for n in value] if attr == "node" else value)
    if args.can_config and not Path(args.can_config).is_absolute():
        args.can_config = str(path.resolve().parent / args.can_config)
    print(f"emulate-drive: the drives of '{name}' in {path}", file=sys.stderr)
    return params


def replay(args: argparse.Namespace) -> int:
    """A run's frame log decoded to SI values (CSV), or played onto a bus."""
    import can

    from twmr.hw.bus import bus_options, describe
    from twmr.hw.replay import Decoder, decode_log, play

    log = Path(args.log)
    if not log.is_file():
        raise CosimError(f"{log}: no such frame log. Fix: give the <name>_frames.blf (or .asc) "
                         f"that `twmr run` wrote beside the results.")
    if args.play:
        try:
            options = bus_options(args.interface, args.channel, args.bitrate,
                                  args.can_config or "", args.can_context)
            n = play(log, options, paced=not args.fast)
        except (OSError, ValueError, ImportError, can.CanError) as err:
            raise CosimError(f"replay --play: cannot send {log} ({err}). Fix: give a "
                             f"python-can --interface and --channel that exist here, or "
                             f"--can-config.") from None
        print(f"{n} frames of {log} sent on {describe(options)}", file=sys.stderr)
        return 0
    given = protocol_options("replay", args.protocol, args.option)
    decoder = Decoder(args.protocol, args.gear, tuple(given.items()))
    for key, what, fix in decoder.problems():
        raise CosimError(f"replay: {_flag(key, given)}: {what} Fix: {fix}")
    bad: list[str] = []
    try:
        decoded = decode_log(log, decoder, bad)
    except Exception as err:  # noqa: BLE001 - python-can's readers raise many kinds
        raise CosimError(f"{log}: cannot read it as a frame log ({type(err).__name__}: {err}). "
                         f"Fix: give the .blf or .asc file `twmr run` wrote beside the results."
                         ) from None
    if not decoded:
        extra = f" ({_frames(len(bad))} too short for {args.protocol}, e.g. {bad[0]})" \
            if bad else ""
        raise CosimError(f"{log}: no {args.protocol} frames found in it{extra}. Fix: check "
                         f"--protocol (one of {', '.join(protocols())}) and its --option "
                         f"values, "
                         f"and that this is a bench run's frame log.")
    if bad:
        print(f"{log}: {_frames(len(bad))} of the log too short for {args.protocol}, skipped "
              f"(first: {bad[0]})", file=sys.stderr)
    first = decoded[0].time
    print(f"{log}: {len(decoded)} values; time_s is seconds since the log's first frame, at "
          f"{datetime.fromtimestamp(first, timezone.utc).isoformat(timespec='milliseconds')}",
          file=sys.stderr)
    out = open(args.out, "w") if args.out else sys.stdout  # noqa: SIM115 - closed below
    try:
        out.write("time_s,direction,node,signal,value\n")
        for d in decoded:
            out.write(f"{d.time - first:.6f},{d.direction},{'' if d.node is None else d.node},"
                      f"{d.signal},{d.value:.9g}\n")
    finally:
        if out is not sys.stdout:
            out.close()
    return 0


def protocol_options(command: str, name: str, pairs: list[str]) -> dict[str, Any]:
    """`--option NAME=VALUE` pairs as values of protocol `name`'s own options (its
    `Link.Options`), each converted to the option's type; CosimError naming the pair at fault
    and the protocol's options otherwise."""
    from twmr.hw.link import option_parameters, protocol

    known = option_parameters(protocol(name).Options)
    values: dict[str, Any] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        key = key.strip()
        if not sep or key not in known:
            listed = ", ".join(known) or "none"
            raise CosimError(f"{command}: --option {pair}: "
                             f"{'not NAME=VALUE' if not sep else f'{key} is not an option'} "
                             f"of protocol {name}. Fix: give NAME=VALUE with a NAME of its "
                             f"options ({listed}).")
        var = known[key]
        try:
            value: Any = text if var.type == "String" else \
                (text.strip().lower() in ("1", "true", "yes") if var.type == "Boolean"
                 else (int(text) if var.type == "Integer" else float(text)))
            values[key] = var.coerce(value)
        except (TypeError, ValueError) as err:
            raise CosimError(f"{command}: --option {pair}: {err}. Fix: give {key} as "
                             f"{var.type.lower()}{f' [{var.unit}]' if var.unit else ''}."
                             ) from None
    return values


def _flag(key: str, given: dict[str, Any]) -> str:
    """How the command line named parameter `key`: --option key=VALUE, or its own flag."""
    if key in ("gear", "node", "nodes"):
        return f"--{key}"
    return f"--option {key}={given[key]}" if key in given else f"--option {key}"


def _frames(n: int) -> str:
    return f"{n} frame" if n == 1 else f"{n} frames"


def _axis_text(axis: Any) -> str:
    state = getattr(axis.state, "value", axis.state)
    error = f" err 0x{axis.error:x}" if getattr(axis, "error", 0) else ""
    return f"state {state}{error} torque {axis.torque:.3g} N.m"


OPTION_HELP = ("an option of --protocol, repeatable (e.g. firmware=0.6.10 for odrive, eds=FILE for "
               "cia402; a NAME it does not have lists the ones it has)")


def emulate_device(args: argparse.Namespace) -> int:
    """A device of a CAN database (`--node`) on a python-can bus: it sends its messages, values
    from `--set`, a data file's columns named `Message.Signal`, or the file's initial values,
    and answers remote frames, until `--duration` or Ctrl-C."""
    from twmr.api import simulate
    from twmr.hw.bus import describe
    from twmr.hw.can_io import CanDevice
    from twmr.result import read_result

    dbc = Path(args.dbc).resolve()
    bus = {"can_config": str(Path(args.can_config).resolve())} if args.can_config else \
        {"interface": args.interface, "channel": args.channel, "bitrate": args.bitrate}
    device = CanDevice("device", dbc=str(dbc), node=args.node)
    for _key, what, fix in device.check(frozenset()):
        raise CosimError(f"emulate-device: {what} Fix: {fix}")
    initial: dict[str, float] = {}
    for pair in args.set:
        key, sep, text = pair.partition("=")
        if not sep or key.strip() not in device.inputs:
            raise CosimError(f"emulate-device: --set {pair}: {key.strip()!r} is no signal the "
                             f"device sends. Fix: give Message.Signal=VALUE with one of "
                             f"{', '.join(list(device.inputs)[:8])}.")
        initial[key.strip()] = float(text)
    components: dict[str, Any] = {"device": {"kind": "can_device", "parameters": {
        "dbc": str(dbc), "node": args.node, "send_mode": args.send_mode, "log_file": "",
        **bus}, "initial": initial}}
    wires = []
    if args.data:
        columns = [c for c in read_result(Path(args.data)).columns if c in device.inputs]
        if not columns:
            raise CosimError(f"emulate-device: {args.data} has no column named as a signal the "
                             f"device sends (Message.Signal). Fix: name its columns so, e.g. "
                             f"{next(iter(device.inputs), 'Message.Signal')}.")
        for k, column in enumerate(columns):
            components[f"data{k}"] = {"kind": "data", "parameters": {
                "file": str(Path(args.data).resolve()), "columns": [column]}}
            wires.append(f"data{k}.y -> device.{column}")
    scenario = {"description": f"twmr emulate-device {dbc.name} --node {args.node}",
                "components": components, "connections": wires,
                "experiment": {"start": 0.0, "stop": args.duration, "step": args.step,
                               "realtime": True},
                "record": {"signals": [], "decimation": 1}}
    sends = ", ".join(m.name for m in device.tx.values()) or "nothing"
    hears = ", ".join(m.name for m in device.rx.values()) or "nothing"
    print(f"emulating node {args.node} of {dbc.name} on "
          f"{describe(bus) if 'interface' in bus else bus['can_config']}: sends {sends}; "
          f"receives {hears}; Ctrl-C stops", file=sys.stderr)
    with contextlib.suppress(KeyboardInterrupt):
        simulate(scenario)
    return 0


def register(subparsers: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    """Add `emulate-drive` and `replay` to the command line."""
    em = subparsers.add_parser("emulate-drive", parents=[common],
                               help="emulated drives on a CAN bus (no hardware)")
    em.add_argument("--scenario", help="a bench scenario: its can_drive's protocol, node ids, "
                    "options (torque constant, firmware, ...) and bus are the defaults of the "
                    "flags not given")
    em.add_argument("--component", help="with --scenario: which can_drive (if it has several)")
    em.add_argument("--protocol", choices=protocols(), help="default odrive")
    em.add_argument("--interface", help="default virtual")
    em.add_argument("--channel", help="default twmr")
    em.add_argument("--bitrate", type=int, help="default 1000000")
    em.add_argument("--can-config", help="python-can config file (replaces interface/channel)")
    em.add_argument("--can-context", help="section of --can-config (default 'default')")
    em.add_argument("-o", "--option", action="append", default=[], metavar="NAME=VALUE",
                    help=OPTION_HELP)
    em.add_argument("--gear", type=float, help="default 1")
    em.add_argument("--node", type=int, action="append", default=None,
                    help="axis node id (repeatable; default: the protocol's, ODrive 0 and 1, "
                    "CiA 402 1 and 2)")
    em.set_defaults(fn=emulate_drive)
    ed = subparsers.add_parser("emulate-device", parents=[common],
                               help="a device of a CAN database (DBC, ARXML, KCD) on a CAN bus")
    ed.add_argument("dbc", help="the CAN database (.dbc, .arxml, .kcd, .sym)")
    ed.add_argument("--node", required=True, help="the device: a node of the file")
    ed.add_argument("--set", action="append", default=[], metavar="MESSAGE.SIGNAL=VALUE",
                    help="a value it sends (repeatable; others: the file's initial values)")
    ed.add_argument("--data", help="CSV, Parquet or .mat file, or a run's folder: columns "
                    "named Message.Signal over a time column 'time' are played")
    ed.add_argument("--send-mode", default="cyclic", help="cyclic (the file's cycle times) | "
                    "on_change | every_step | on_request")
    ed.add_argument("--step", type=float, default=0.01, help="the device's step [s]")
    ed.add_argument("--duration", type=float, default=24 * 3600.0, help="[s] (default a day)")
    ed.add_argument("--interface", default="udp_multicast")
    ed.add_argument("--channel", default="239.74.163.2")
    ed.add_argument("--bitrate", type=int, default=500_000)
    ed.add_argument("--can-config", help="python-can config file (replaces interface/channel)")
    ed.set_defaults(fn=emulate_device)
    rp = subparsers.add_parser("replay", parents=[common],
                               help="decode a run's CAN frame log to CSV, or play it onto a bus")
    rp.add_argument("log", help="<name>_frames.blf or .asc written beside the results")
    rp.add_argument("--protocol", choices=protocols(), default="odrive")
    rp.add_argument("--gear", type=float, default=1.0, help="motor turns per wheel turn")
    rp.add_argument("-o", "--option", action="append", default=[], metavar="NAME=VALUE",
                    help=OPTION_HELP)
    rp.add_argument("--out", help="CSV file (default: standard output)")
    rp.add_argument("--play", action="store_true", help="send the frames onto a bus instead")
    rp.add_argument("--fast", action="store_true", help="with --play: no original timing")
    rp.add_argument("--interface", default="virtual")
    rp.add_argument("--channel", default="twmr")
    rp.add_argument("--bitrate", type=int, default=1_000_000)
    rp.add_argument("--can-config", help="python-can config file (replaces interface/channel)")
    rp.add_argument("--can-context", default="default")
    rp.set_defaults(fn=replay)
