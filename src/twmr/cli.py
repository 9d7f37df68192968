"""`twmr` command line: run | check | components | plot | inspect | export | compare |
emulate-drive | replay.

Errors a user can cause (`CosimError`) print as one paragraph, without a traceback (`--debug`
shows it), and exit with status 1; results computed before a failure are already on disk.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

from twmr.core.errors import CosimError


def _out_dir(args: argparse.Namespace, scenario: Path) -> Path:
    return Path(args.out) if args.out else Path("results") / scenario.stem


def cmd_run(args: argparse.Namespace) -> int:
    from twmr.analysis.plots import plot_result, plot_timing
    from twmr.analysis.results import save_csv, save_mat, save_summary, summary
    from twmr.master import Execution
    from twmr.scenario import load

    scenario = Path(args.scenario)
    system = load(scenario, args.set)
    if args.realtime:
        from dataclasses import replace

        system.experiment = replace(system.experiment, realtime=True)
    out = _out_dir(args, scenario)
    out.mkdir(parents=True, exist_ok=True)
    ex = Execution(system, out / "result.npy", progress=not args.quiet)
    exp = system.experiment
    print(f"running {scenario} ({len(system.components)} components, {exp.n_steps} steps of "
          f"{exp.step:g} s, {exp.algorithm}) -> {out}/", file=sys.stderr)
    error: CosimError | KeyboardInterrupt | None = None
    try:
        data = ex.run()
    except (CosimError, KeyboardInterrupt) as err:
        error = err
        import numpy as np

        data = np.load(out / "result.npy")
    units = ex.recorder.units
    info: dict[str, Any] = {
        "scenario": str(scenario), "overrides": list(args.set), "algorithm": exp.algorithm,
        "start": exp.start, "stop": exp.stop, "step": exp.step, "steps_done": ex.info.steps_done,
        "wall_time_s": round(ex.info.wall_time, 4),
        "realtime_factor": round(ex.info.realtime_factor, 2), "error": ex.info.error,
        "units": units, "signals": summary(data, units), "pacing": ex.info.extra,
    }
    metrics = _tracking_metrics(data)
    if metrics:
        info["metrics"] = metrics
    save_summary(info, out / "summary.json")
    if "csv" in args.format:
        save_csv(data, units, out / "result.csv")
    if "mat" in args.format:
        save_mat(data, units, out / "result.mat")
    if ex.pacer is not None and ex.pacer.released_ns:
        import numpy as np

        np.save(out / "lateness_us.npy", ex.pacer.lateness_us())
    if args.plot:
        plot_result(data, units, out / "plots", title=scenario.stem)
        if ex.pacer is not None and ex.pacer.released_ns:
            plot_timing(ex.pacer.lateness_us(), exp.step, out / "plots" / "timing.png",
                        scenario.stem)
    if error is not None:
        raise error
    print(f"done: {ex.info.steps_done} steps in {ex.info.wall_time:.2f} s "
          f"({ex.info.realtime_factor:.1f}x real time); results in {out}/", file=sys.stderr)
    if ex.info.extra:
        print("pacing: " + ", ".join(f"{k} {v:.4g}" for k, v in ex.info.extra.items()),
              file=sys.stderr)
    if metrics:
        print(json.dumps(metrics))
    return 0


def _tracking_metrics(data: Any) -> dict[str, Any]:
    """Table III metrics when the result has a tracking error (optional analysis package)."""
    try:
        from twmr.analysis.metrics import tracking_metrics
    except ImportError:
        return {}
    return tracking_metrics(data)


def cmd_check(args: argparse.Namespace) -> int:
    from twmr.scenario import describe, load

    system = load(Path(args.scenario), args.set)
    print(describe(system))
    print("OK: the scenario is valid.")
    return 0


def cmd_components(args: argparse.Namespace) -> int:
    from twmr.scenario import kinds_table

    print(kinds_table(args.kinds or None))
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from twmr.analysis.plots import plot_result
    from twmr.analysis.results import load_result

    path = Path(args.result)
    if not path.exists():
        raise CosimError(f"{path}: no such result file or directory. Fix: give the directory "
                         f"`twmr run` wrote (results/<scenario>) or one of its result files.")
    data, units = load_result(path)
    out = Path(args.out) if args.out else (path if path.is_dir() else path.parent) / "plots"
    for p in plot_result(data, units, out, title=path.stem):
        print(p)
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    from twmr.fmi import describe_fmu

    print(describe_fmu(Path(args.fmu)))
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from twmr.fmi import export_component

    params = dict(_parse_set(s) for s in args.set)
    path = export_component(args.kind, Path(args.out or f"fmus/{args.kind}.fmu"), params)
    print(path)
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from twmr.analysis.compare import compare

    return compare([Path(s) for s in args.scenarios], as_json=args.json,
                   out=Path(args.out) if args.out else None, overrides=args.set)


def cmd_emulate_drive(args: argparse.Namespace) -> int:
    """Emulated drives (ODrive or CiA 402) answering on a python-can bus until Ctrl-C."""
    try:
        from twmr.hw.bus import bus_options, describe
    except ImportError as err:
        raise CosimError(f"the hardware extra is missing ({err}). Fix: pip install "
                         f"'twmr-cosim[hw]'.") from None
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
    except (OSError, ValueError, ImportError) as err:
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


def cmd_replay(args: argparse.Namespace) -> int:
    """A run's frame log decoded to SI values (CSV), or played onto a bus."""
    try:
        from twmr.hw.bus import bus_options, describe
        from twmr.hw.replay import Decoder, decode_log, play
    except ImportError as err:
        raise CosimError(f"the hardware extra is missing ({err}). Fix: pip install "
                         f"'twmr-cosim[hw]'.") from None
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
    out = open(args.out, "w") if args.out else sys.stdout  # noqa: SIM115 - closed below
    try:
        out.write("time_s,direction,node,signal,value\n")
        for d in decode_log(log, decoder):
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


def _parse_set(text: str) -> tuple[str, Any]:
    import yaml

    key, sep, value = text.partition("=")
    if not sep:
        raise CosimError(f"--set {text!r}: expected name=value. Fix: e.g. --set k=2.0")
    return key.strip(), yaml.safe_load(value)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="twmr", description="Co-simulation of wheeled mobile robots.")
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", required=True)

    def with_set(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--set", action="append", default=[], metavar="COMP.PARAM=VALUE",
                        help="override a parameter or initial value (repeatable)")

    r = sub.add_parser("run", help="run a scenario; save results, summary and plots")
    r.add_argument("scenario")
    with_set(r)
    r.add_argument("--out", help="output directory (default results/<scenario name>)")
    r.add_argument("--plot", action="store_true", help="write PNG plots of the recorded signals")
    r.add_argument("--format", default="csv,mat", help="extra result files: csv,mat (default)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--realtime", action="store_true",
                   help="pace steps to the wall clock (automatic with hardware components)")
    r.set_defaults(fn=cmd_run)
    c = sub.add_parser("check", help="validate a scenario and print its graph, order and units")
    c.add_argument("scenario")
    with_set(c)
    c.set_defaults(fn=cmd_check)
    k = sub.add_parser("components", help="list component kinds with ports, parameters, units")
    k.add_argument("kinds", nargs="*")
    k.set_defaults(fn=cmd_components)
    pl = sub.add_parser("plot", help="plot a result (directory, .npy, .csv or .mat)")
    pl.add_argument("result")
    pl.add_argument("--out")
    pl.set_defaults(fn=cmd_plot)
    i = sub.add_parser("inspect", help="describe an FMU as a component")
    i.add_argument("fmu")
    i.set_defaults(fn=cmd_inspect)
    e = sub.add_parser("export", help="export a native component kind as an FMU 2.0 (CS)")
    e.add_argument("kind")
    e.add_argument("--out")
    with_set(e)
    e.set_defaults(fn=cmd_export)
    em = sub.add_parser("emulate-drive", help="emulated drives on a CAN bus (no hardware)")
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
                    help="axis node id (repeatable; default 0 and 1)")
    em.set_defaults(fn=cmd_emulate_drive)
    rp = sub.add_parser("replay", help="decode a run's CAN frame log to CSV, or play it onto a bus")
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
    rp.set_defaults(fn=cmd_replay)
    cp = sub.add_parser("compare", help="run scenarios and print Table III metrics side by side")
    cp.add_argument("scenarios", nargs="+")
    cp.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    cp.add_argument("--out", help="directory for the comparison figures")
    with_set(cp)
    cp.set_defaults(fn=cmd_compare)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if getattr(args, "command", "") == "emulate-drive" and not args.node:
        args.node = [0, 1]
    t0 = time.perf_counter()
    try:
        return int(args.fn(args) or 0)
    except CosimError as err:
        if args.debug:
            raise
        print(f"error: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted after {time.perf_counter() - t0:.1f} s; results so far are saved.",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
