"""`twmr` command line: run | check | sweep | sweep-report | tune | fit | linearize | analyze |
components | plot | verify | inspect | export, plus the subcommands installed packages register
(`twmr.commands` entry points: compare, emulate-drive, replay).

Errors a user can cause (`CosimError`) print as one paragraph, without a traceback (`--debug`
shows it), and exit with status 1; results computed before a failure are already on disk.
Messages go through `logging` (logger `twmr`): `-q` only warnings and errors, `-v` debug too.
Heavy libraries are imported inside the commands that use them, so `twmr` starts fast.
"""
from __future__ import annotations

import sys


def _interrupted_at_start() -> int:
    """Ctrl-C before the command began (while modules were still being imported)."""
    sys.stderr.write("interrupted (Ctrl-C) while twmr was starting; nothing was done.\n")
    return 130


try:
    import argparse
    import contextlib
    import logging
    import time
    from collections.abc import Sequence
    from pathlib import Path
    from typing import Any

    from twmr import __version__
    from twmr.core.errors import CosimError
except KeyboardInterrupt:
    raise SystemExit(_interrupted_at_start()) from None

log = logging.getLogger("twmr")


def _out_dir(args: argparse.Namespace, scenario: Path) -> Path:
    """--out, else results/<scenario name> with the name made a plain folder name."""
    if args.out is not None:
        if not args.out.strip():
            raise CosimError("--out is empty. Fix: give a folder, e.g. --out results/run1.")
        return Path(args.out)
    import re

    return Path("results") / (re.sub(r"[^\w.-]", "_", scenario.stem).lstrip(".") or "scenario")


def _formats(text: str) -> tuple[str, ...]:
    """The registered result formats a comma list names ('none': no export)."""
    from twmr.observers.writers import result_formats

    chosen = tuple(f.strip() for f in text.split(",") if f.strip() and f.strip() != "none")
    try:
        result_formats(chosen)
    except CosimError as err:
        raise CosimError(f"--format {text}: {err} Or give none.") from None
    return chosen


def cmd_run(args: argparse.Namespace) -> int:
    from twmr import api
    from twmr.core.run import Options
    from twmr.master.stats import lines

    scenario_path = Path(args.scenario)
    overrides = list(args.set) + ([f"experiment.realtime={args.realtime}"]
                                  if args.realtime else [])
    options = Options(compiled=args.compiled or None, fmu_log=args.fmu_log,
                      timing=getattr(args, "verbose", False))  # time per block, in summary.json
    formats = _formats(args.format)
    metrics = [m.strip() for m in ",".join(args.metrics).split(",") if m.strip()]
    scenario = api.load(scenario_path, overrides)
    exp = scenario.system.experiment
    out = _out_dir(args, scenario_path)
    log.info("running %s (%d components, %d steps of %g s, %s) -> %s/", scenario_path,
             len(scenario.system.components), exp.n_steps, exp.step, exp.algorithm, out)
    live = _live_view(args)
    foxglove = _foxglove_server(args)
    try:
        result = api.simulate(scenario, out, formats=formats, metrics=metrics,
                              progress=not args.quiet, options=options,
                              observers=[o for o in (live, foxglove) if o is not None],
                              gate=live.gate if live is not None else None)
    except (CosimError, KeyboardInterrupt) as err:
        folder = getattr(err, "partial_results", None)
        if folder is not None and args.plot:
            _plots(api.read_result(folder), scenario_path.stem)
        raise
    finally:
        if foxglove is not None:
            foxglove.close()
        if live is not None:
            if live.keep and not isinstance(sys.exc_info()[1], KeyboardInterrupt):
                log.warning("the run ended; the live view stays up at %s until Ctrl-C",
                            live.url)
                live.wait()
            live.close()
    if args.plot:
        _plots(result, scenario_path.stem)
    s = result.summary
    if s.get("stopped_by"):
        log.info("%s asked to end the simulation at t = %g s (experiment.fmu_terminate: stop)",
                 s["stopped_by"]["component"], s["stopped_by"]["time"])
    figures = s.get("pacing") or {}
    compiled = ""
    if figures.get("algorithm.compiled"):
        took = figures.get("algorithm.compile_s", float("nan"))
        at = figures.get("algorithm.compiled_at_step") or 0
        compiled = (f", {took:.2f} s of it compiling the step loop (numba) after {at} steps "
                    f"in Python" if at else f", after {took:.2f} s to compile the step loop "
                    f"(numba; or load it from its cache)")
    log.info("done: %d steps in %.2f s (%.1fx real time)%s; results in %s/", s["steps_done"],
             s["wall_time_s"], s["realtime_factor"], compiled, result.folder)
    if figures.get("algorithm.not_compiled"):
        log.debug("Python step loop: %s", figures["algorithm.not_compiled"])
    elif figures.get("algorithm.compiled"):
        form = "the driver (each kind of block compiled once)" if figures.get(
            "algorithm.driver") else "the loop generated for this system"
        log.debug("compiled step loop: %s; compiled because %s", form,
                  figures.get("algorithm.why") or "asked")
    statistics = lines(s.get("statistics") or {})
    if statistics:
        log.debug("per block and algebraic loop:\n%s", "\n".join(statistics))
    pacing = {k: v for k, v in figures.items() if not k.startswith("algorithm.")
              and k != "start_unix_s" and isinstance(v, (int, float))}
    if pacing:
        log.info("pacing: %s", ", ".join(f"{k} {v:.4g}" for k, v in pacing.items()))
    if s.get("metrics"):
        from twmr.core import jsonvalues

        print(jsonvalues.dumps(s["metrics"]))
    return 0


def _foxglove_server(args: argparse.Namespace) -> Any:
    """The `--foxglove` server, started (its address printed), or None."""
    if args.foxglove is None:
        return None
    from twmr.observers.foxglove_live import FoxgloveServer

    server = FoxgloveServer(args.foxglove)
    print(f"foxglove: open connection {server.start()}", file=sys.stderr, flush=True)
    return server


def _live_view(args: argparse.Namespace) -> Any:
    """The `--live` server, started (its URL printed), or None."""
    if args.live is None:
        if args.live_keep:
            raise CosimError("--live-keep keeps the live view up after the run, and there is "
                             "none. Fix: add --live PORT (e.g. --live 0), or drop --live-keep.")
        return None
    from twmr.master.gate import Gate
    from twmr.observers.live import LiveView

    live = LiveView(args.live, keep=args.live_keep, gate=Gate())
    print(f"live view: {live.start()}", file=sys.stderr, flush=True)
    return live


def _plots(result: Any, title: str) -> None:
    from twmr.plots import event_marks, plot_result, plot_timing

    folder = result.folder
    if len(result):
        plot_result(result.data, result.units, folder / "plots", title=title,
                    ports=result.summary.get("ports"), marks=event_marks(result.summary))
    lateness = folder / "lateness_us.npy"
    if lateness.is_file():
        import numpy as np

        plot_timing(np.load(lateness), float(result.summary.get("step", 0.0)),
                    folder / "plots" / "timing.png", title)


def cmd_check(args: argparse.Namespace) -> int:
    from twmr.api import load
    from twmr.fmi.guard import isolation_advice
    from twmr.master.algorithm import algorithm_for
    from twmr.scenario.flatten import has_subsystems
    from twmr.scenario.listing import describe, tree

    scenario = load(Path(args.scenario), args.set)
    system = scenario.system
    algorithm = algorithm_for(system)
    print(describe(system))
    if has_subsystems(scenario.spec):
        print("tree (subsystems and the ports they expose):")
        print("\n".join(tree(scenario.spec)))
    for advice in isolation_advice(system.components):
        log.warning("warning: %s", advice)
    if args.schedule:
        algorithm.prepare(system, list(system.record.signals), system.record.decimation)
        print("generated step loop:")
        print(algorithm.source or f"(the algorithm '{system.experiment.algorithm}' generates "
                                  f"no source)")
    print("OK: the scenario is valid.")
    return 0


def cmd_diagram(args: argparse.Namespace) -> int:
    from twmr.api import load
    from twmr.diagram import closed_subsystems, diagram_svg

    path = Path(args.scenario)
    system = load(path, args.set).system
    try:
        closed = closed_subsystems(system, args.closed or [])
    except ValueError as err:
        raise CosimError(str(err)) from None
    out = Path(args.out) if args.out else path.with_suffix(".svg")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(diagram_svg(system, title=path.name, closed=closed), encoding="utf-8")
    print(out)
    return 0


def cmd_components(args: argparse.Namespace) -> int:
    from twmr.registry import kinds, suggest
    from twmr.scenario.listing import kinds_table

    unknown = [k for k in args.kinds if k not in kinds() and ":" not in k]
    if unknown:
        raise CosimError(f"unknown component kind '{unknown[0]}'{suggest(unknown[0], kinds())}. "
                         f"Fix: `twmr components` lists them all.")
    print(kinds_table(args.kinds or None))
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from twmr.plots import event_marks, plot_result
    from twmr.result import read_result

    paths = [Path(p) for p in args.result]
    results = [read_result(p) for p in paths]
    for path, result in zip(paths, results, strict=True):
        if not len(result):
            log.warning("warning: %s holds no samples (a header without rows, or a run cut "
                        "short before its first rows reached the disk): its figures are empty.",
                        path)
    first = paths[0]
    out = Path(args.out) if args.out else (first if first.is_dir() else first.parent) / "plots"
    if len(results) == 1 and not args.signals:
        for p in plot_result(results[0].data, results[0].units, out, title=first.stem,
                             ports=results[0].summary.get("ports"),
                             marks=event_marks(results[0].summary)):
            print(p)
        return 0
    labels = [p.stem if p.stem not in ("result", "") else p.parent.name for p in paths]
    try:
        plotted = results[0].plot(args.signals or None, label=labels[0],
                                  others=dict(zip(labels[1:], results[1:], strict=True)))
    except KeyError as err:
        raise CosimError(f"--signals {args.signals!r}: {err.args[0]}. Fix: name recorded "
                         f"signals (twmr plot with one result draws them all).") from None
    from twmr.plots import save

    for p in save(plotted, out / "overlay.png"):
        print(p)
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    from twmr.fitting import Experiment, fit

    pairs = {}
    for part in ",".join(args.match).split(","):
        model, _, column = part.partition("=")
        if model.strip():
            pairs[model.strip()] = column.strip() or model.strip()
    sigma = {}
    for part in args.sigma:
        name, sep, value = part.partition("=")
        try:
            sigma[name.strip()] = float(value)
        except ValueError:
            raise CosimError(f"--sigma {part!r}: not NAME=VALUE. Fix: e.g. --sigma "
                             f"plant.pose[1]=0.01.") from None
        if not sep:
            raise CosimError(f"--sigma {part!r}: not NAME=VALUE. Fix: e.g. --sigma "
                             f"plant.pose[1]=0.01.")
    scenario = Path(args.scenario)
    out = Path(args.out) if args.out else Path("fits") / (scenario.stem or "scenario")
    result = fit(scenario, [Experiment(d, until=args.until) for d in args.data], args.estimate,
                 pairs, sigma=sigma, overrides=args.set, out=out, max_runs=args.max_runs,
                 starts=args.starts, seed=args.seed, workers=args.workers,
                 scheduler=args.scheduler)
    print(result.text())
    print(f"fit.json, fitted.yaml and residuals.png in {out}/")
    return 0


def cmd_linearize(args: argparse.Namespace) -> int:
    import json

    import numpy as np

    from twmr import api
    from twmr.linear_analysis import bode_figure, linearize, loop_at, nyquist_figure, source_of

    scenario = api.load(Path(args.scenario), args.set)
    inputs, outputs = list(args.input), list(args.output)
    lines = _trimmed(scenario, args)
    if args.trim:
        scenario = api.load(Path(args.scenario), args.set)
    if args.fmu:
        return _linearize_fmu(scenario, args, lines)
    if args.loop:
        source = source_of(scenario, args.loop)
        if not source or inputs or outputs:
            raise CosimError(f"--loop {args.loop}: " + ("give it alone, without --input and "
                             "--output." if source else "no wire feeds this input. Fix: give "
                             "an input port a wire feeds (COMP.PORT)."))
        inputs, outputs = [args.loop], [source]
    model = linearize(scenario, inputs, outputs, at=args.at, horizon=args.horizon,
                      amplitude=args.amplitude, order=args.order, tol=args.tol)
    out = Path(args.out) if args.out else Path("linear") / Path(args.scenario).stem
    out.mkdir(parents=True, exist_ok=True)
    plain = model.plain()
    if args.trim:
        plain["trim"] = args.trim_point
    loop = loop_at(model) if args.loop else None
    lines += [f"linear model at t = {model.at:g} s, step {model.dt:g} s: {model.order} states; "
             f"fit error {model.fit_error:.2g}, nonlinearity {model.nonlinearity:.2g}",
             "discrete poles z: " + ", ".join(
                 f"{complex(z):.6g}" for z in np.sort_complex(model.poles()))]
    lines += _analysis_lines(plain)
    if loop is not None:
        import control

        gm, pm, wcg, wcp = control.margin(loop)
        plain["loop"] = {"gain_margin": gm, "phase_margin_deg": pm, "phase_crossover_rad_s": wcg,
                         "gain_crossover_rad_s": wcp}
        lines.append(f"loop at {args.loop} (fed by {outputs[0]}): gain margin {gm:.6g} "
                     f"({20 * np.log10(gm):.4g} dB) at {wcg:.6g} rad/s, phase margin {pm:.6g} "
                     f"deg at {wcp:.6g} rad/s")
    (out / "linear.json").write_text(json.dumps(plain, indent=2))
    np.savez(out / "linear.npz", A=model.A, B=model.B, C=model.C, D=model.D, dt=model.dt,
             markov=model.markov)
    try:
        (out / "state_space.yaml").write_text(model.block_yaml())
    except CosimError as err:
        lines.append(f"no state_space.yaml: {err}")
    bode_figure(model, out / "bode", loop)
    written = "linear.json, linear.npz, state_space.yaml and bode.png"
    if loop is not None:
        nyquist_figure(loop, model.dt, out / "nyquist", f"loop at {args.loop}")
        written += ", nyquist.png"
    if args.design:
        lines += _design(model, args, out)
        written += ", design.json, controller.yaml"
    print("\n".join(lines))
    print(f"{written} in {out}/")
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    """`twmr analyze FOLDER`: a saved linear model's poles, zeros, ranks, step response and
    (a loop) margins, with its Bode, step and Nyquist figures."""
    import numpy as np

    from twmr.linear_analysis import bode_figure, loop_at, nyquist_figure, read_model, step_figure

    model, loop_input = read_model(args.folder)
    out = Path(args.out) if args.out else Path(args.folder)
    out.mkdir(parents=True, exist_ok=True)
    plain = model.plain()
    lines = [f"{model.order} states at step {model.dt:g} s, around t = {model.at:g} s: inputs "
             f"{', '.join(model.inputs)}; outputs {', '.join(model.outputs)}",
             "discrete poles z: " + ", ".join(f"{complex(z):.6g}"
                                            for z in np.sort_complex(model.poles())),
             *_analysis_lines(plain)]
    loop = loop_at(model) if loop_input else None
    written = ["bode.png"]
    bode_figure(model, out / "bode", loop)
    if loop is not None:
        import control

        gm, pm, wcg, wcp = control.margin(loop)
        lines.append(f"loop at {loop_input}: gain margin {gm:.6g} ({20 * np.log10(gm):.4g} dB) "
                     f"at {wcg:.6g} rad/s, phase margin {pm:.6g} deg at {wcp:.6g} rad/s")
        nyquist_figure(loop, model.dt, out / "nyquist", f"loop at {loop_input}")
        written.append("nyquist.png")
    if "step" in plain:
        step_figure(model, out / "step")
        written.append("step.png")
    print("\n".join(lines))
    print(f"{', '.join(written)} in {out}/")
    return 0


def _analysis_lines(plain: dict[str, Any]) -> list[str]:
    """Zeros, controllability and observability, and (one input, one output) the step
    response's figures of a linear model's `plain()`."""
    zeros = ", ".join(f"{complex(re, im):.6g}" for re, im in plain["zeros"]) or "none"
    c, o = plain["controllability"], plain["observability"]
    lines = [f"zeros z: {zeros}",
             f"controllable: rank {c['rank']} of {c['of']} (condition {c['condition']:.3g}); "
             f"observable: rank {o['rank']} of {o['of']} (condition {o['condition']:.3g})"]
    step = plain.get("step")
    if step is None:
        lines.append("step response: none (the model is not stable)")
    elif len(step) == 1 and len(step[0]) == 1:
        s = step[0][0]
        lines.append(f"step response: rise {s['RiseTime']:.4g} s, settling (2 %) "
                     f"{s['SettlingTime']:.4g} s, overshoot {s['Overshoot']:.3g} %, final "
                     f"value {s['SteadyStateValue']:.6g}")
    return lines


def _trimmed(scenario: Any, args: argparse.Namespace) -> list[str]:
    """`--trim`: the trim point solved for (its `--set` texts appended to args.set, the point at
    the start); `--at` checked; the lines to print."""
    from twmr.linear_trim import trim

    if not args.trim:
        if args.at is None:
            raise CosimError("linearize needs a point. Fix: give --at T (a time of the run), "
                             "--at steady (where the run settles) or --trim COMP.STATE (an "
                             "equilibrium solved for).")
        return []
    if args.at is not None:
        raise CosimError("--trim solves for the steady point at the start: give it without "
                         "--at (set the start with --set experiment.start=T).")
    point = trim(scenario, [n for t in args.trim for n in t.split(",") if n.strip()],
                 outputs=[n for t in args.trim_output for n in t.split(",") if n.strip()])
    args.set = [*args.set, *point.overrides]
    args.at = float(scenario.system.experiment.start)
    args.trim_point = point.plain()
    lines = [f"trim point ({point.iterations} Newton iterations, {point.runs} one-step runs; "
             f"largest change per step {point.change:.2g}): {', '.join(point.overrides)}"]
    if point.step_matrix is not None:
        import numpy as np

        lines.append("poles z of the trimmed values' step map there (finite differences, "
                     f"error {point.step_matrix_error:.1g}): " + ", ".join(
                         f"{complex(z):.6g}" for z in np.sort_complex(point.poles())))
    return lines


def _time_or_steady(text: str) -> float | str:
    """--at: a time [s] or 'steady'."""
    if text == "steady":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither a time [s] nor 'steady'") \
            from None


def _linearize_fmu(scenario: Any, args: argparse.Namespace, lines: list[str]) -> int:
    """`twmr linearize --fmu COMP`: the FMU's continuous model by its directional derivatives."""
    import json

    import numpy as np

    from twmr.linear_analysis import linearize_fmu

    if args.input or args.output or args.loop or args.design:
        raise CosimError("--fmu linearises one FMU by its directional derivatives: give it "
                         "alone, without --input, --output, --loop or --design.")
    model = linearize_fmu(scenario, args.fmu, at=args.at, derivatives=args.derivatives)
    out = Path(args.out) if args.out else Path("linear") / Path(args.scenario).stem
    out.mkdir(parents=True, exist_ok=True)
    plain = model.plain()
    if args.trim:
        plain["trim"] = args.trim_point
    (out / "linear.json").write_text(json.dumps(plain, indent=2))
    np.set_printoptions(precision=6, suppress=True)
    if lines:
        print("\n".join(lines))
    print(f"{args.fmu} at t = {model.at:g} s (continuous, by its {model.derivatives} derivatives): "
          f"states {', '.join(model.states)}; inputs {', '.join(model.inputs) or 'none'}; "
          f"outputs {', '.join(model.outputs) or 'none'}")
    print("A =\n" + str(model.A))
    if model.B.size:
        print("B =\n" + str(model.B))
    print("C =\n" + str(model.C))
    print("poles: " + ", ".join(f"{complex(z):.6g}" for z in np.sort_complex(model.poles())))
    print(f"linear.json in {out}/")
    return 0


def _design(model: Any, args: argparse.Namespace, out: Path) -> list[str]:
    """`twmr linearize --design`: the controller's files in `out`; the lines to print."""
    import json

    import numpy as np

    from twmr.linear_design import design

    def poles(text: str, option: str) -> list[complex]:
        try:
            return [complex(z.replace(" ", "")) for z in text.split(",") if z.strip()]
        except ValueError:
            raise CosimError(f"{option} {text!r}: not a list of numbers. Fix: e.g. {option} "
                             f"0.9,0.8 or 0.9+0.1j,0.9-0.1j.") from None

    made = design(model, args.design, q=args.output_weight, r=args.input_weight,
                  w=args.process_noise, v=args.measurement_noise, qi=args.integral_weight,
                  poles=poles(args.poles, "--poles"),
                  observer_poles=poles(args.observer_poles, "--observer-poles"))
    plain = made.plain()
    (out / "design.json").write_text(json.dumps(plain, indent=2))
    lines = [f"{args.design} controller: closed-loop poles z: " + ", ".join(
        f"{complex(z):.6g}" for z in np.sort_complex(made.closed_loop_poles()))]
    if "margins" in plain:
        m = plain["margins"]
        lines.append(f"loop at {model.inputs[0]} with the controller: gain margin "
                     f"{m['gain_margin']:.6g}, phase margin {m['phase_margin_deg']:.6g} deg")
    try:
        (out / "controller.yaml").write_text(made.block_yaml())
    except CosimError as err:
        lines.append(f"no controller.yaml: {err}")
    return lines


def cmd_verify(args: argparse.Namespace) -> int:
    from twmr.verify import Tolerance, plot, verify

    signals = [n.strip() for n in ",".join(args.signals).split(",") if n.strip()] or None
    verdict = verify(args.run, args.reference, Tolerance(args.abs, args.rel, args.shift),
                     signals)
    print(verdict.text())
    if args.plot:
        for p in plot(verdict, args.plot):
            print(p)
    return 0 if verdict.passed else 1


def cmd_inspect(args: argparse.Namespace) -> int:
    from twmr.fmi import describe_fmu, fmu_interface
    from twmr.scenario.loaders import load_ssp, loader_of

    loader = loader_of(Path(args.fmu)) if Path(args.fmu).suffix.lower() != ".fmu" else None
    if loader is not None:
        from twmr.fmi.ssp.listing import describe_ssp
        from twmr.scenario.listing import describe

        scenario = api_load(Path(args.fmu))
        if loader is load_ssp:
            print(describe_ssp(scenario.spec))
        print(describe(scenario.system))
        return 0
    if args.json:
        import json

        print(json.dumps(fmu_interface(Path(args.fmu)), indent=2))
    else:
        print(describe_fmu(Path(args.fmu)))
    return 0


def api_load(path: Path) -> Any:
    from twmr.api import load

    return load(path)


def _is_scenario(args: argparse.Namespace) -> bool:
    """`twmr export` of a whole scenario (to SSP) rather than of one kind (to an FMU)."""
    from twmr.scenario.loaders import loader_of

    return loader_of(Path(args.kind)) is not None or str(args.out or "").lower().endswith(".ssp")


def cmd_export(args: argparse.Namespace) -> int:
    if _is_scenario(args):
        from twmr.fmi.ssp.write import export_ssp

        out = args.out or f"{Path(args.kind).stem}.ssp"
        print(export_ssp(args.kind, out, args.set, fmi=args.fmi, python=args.python,
                         ssp=args.ssp or 1))
        return 0
    if args.ssp is not None:
        raise CosimError("--ssp applies to a scenario exported as SSP. Fix: give a scenario "
                         "file (twmr export SCENARIO.yaml --out X.ssp), or drop --ssp.")
    params = dict(_parse_set(s) for s in args.set)
    out = Path(args.out or f"fmus/{args.kind.rsplit(':', 1)[-1]}.fmu")  # 'file.py:Cls' -> Cls
    if args.python:
        if args.can:
            raise CosimError("--can builds a standalone C FMU (an FMI-LS-BUS CAN node). Fix: "
                             "drop --python.")
        if args.fmi != 2:
            raise CosimError("--python exports FMI 2.0 only (pythonfmu). Fix: drop --fmi 3, or "
                             "drop --python for a standalone C FMU.")
        from twmr.fmi import export_component

        path = export_component(args.kind, out, params)
    else:
        from twmr.fmi.cexport import export_c_fmu

        path = export_c_fmu(args.kind, out, params, fmi=args.fmi, can=args.can)
    print(path)
    return 0


def cmd_fmu_build(args: argparse.Namespace) -> int:
    """A copy of a source-only FMU with a binary for this platform built from its sources."""
    import math

    from twmr.fmi.description import read_description
    from twmr.fmi.sources import DEFAULT_TIMEOUT, binary_folders, build, has_binary

    timeout = DEFAULT_TIMEOUT if args.timeout is None else args.timeout
    path = Path(args.fmu)
    if not path.is_file():
        raise CosimError(f"'{path}' is not an FMU file (it does not exist, or is a folder). "
                         f"Fix: give the source-only FMU to build, e.g. twmr fmu build "
                         f"fmus/vendor.fmu")
    md = read_description(path, path.stem)
    platform = binary_folders(md)[0]
    if has_binary(path, md):
        raise CosimError(f"'{path}' has a binary for this platform ({platform}) already: there "
                         f"is nothing to build. Fix: use the FMU as it is.")
    if not 0 < timeout < math.inf:
        raise CosimError(f"--timeout {timeout:g} is not a positive number of seconds. Fix: "
                         f"give the longest the build may take, e.g. --timeout 120.")
    out = Path(args.out) if args.out else path.with_name(f"{path.stem}.{platform}.fmu")
    print(build(path, md, out, path.stem, timeout))
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from twmr.sweeps import SweepError, SweepSpec, parse_vary, read_sweep_file, sweep

    path = Path(args.scenario)
    file: dict[str, Any] = {}
    scenario = str(path)
    if _is_sweep_file(path):
        file = read_sweep_file(path)
        if not file.get("scenario"):
            raise SweepError(f"{path}: no 'scenario:'. Fix: name the scenario file to sweep.")
        target = Path(str(file["scenario"]))
        scenario = str(target if target.is_absolute() else path.parent / target)
    vary = {v.name: v for v in file.get("vary", [])}
    vary.update({v.name: v for v in (parse_vary(text) for text in args.vary)})
    metrics = [m.strip() for m in ",".join(args.metrics).split(",") if m.strip()] or \
        list(file.get("metrics") or [])

    def option(name: str, default: Any) -> Any:
        given = getattr(args, name)
        return given if given is not None else file.get(name, default)

    spec = SweepSpec(scenario, list(vary.values()), samples=option("samples", 20),
                     method=option("method", "random"), seed=option("seed", 0),
                     metrics=metrics, fixed=[*(file.get("set") or []), *args.set])
    out = Path(option("out", None) or Path("sweeps") / Path(scenario).stem)
    outcome = sweep(spec, out, workers=option("workers", None), scheduler=args.scheduler,
                    keep_signals=args.keep_signals or file.get("keep_signals") is True,
                    dashboard=args.dashboard, progress=not getattr(args, "quiet", False))
    log.info("sweep: %d run(s) done now (%d failed), %d already done; %s", outcome.ran,
             outcome.failed, outcome.skipped, out / "runs.parquet")
    if outcome.ran and outcome.failed == outcome.ran:
        first = next(r["error"] for r in outcome.rows if r["status"] != "ok")
        raise SweepError(f"every run of the sweep failed (their errors are in "
                         f"{out / 'runs.parquet'}); the first: {first}")
    if outcome.failed:
        log.warning("%d run(s) failed; their errors are in %s (`twmr sweep-report %s` lists "
                    "them)", outcome.failed, out / "runs.parquet", out)
    return 0


def _is_sweep_file(path: Path) -> bool:
    """A YAML file with 'vary:' at its top level is a sweep file, not a scenario."""
    import yaml

    if path.suffix.lower() not in (".yaml", ".yml") or not path.is_file():
        return False
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8", errors="replace"))
    except yaml.YAMLError:
        return False
    return isinstance(data, dict) and "vary" in data


def _start_point(text: str) -> dict[str, object]:
    """`NAME=VALUE,NAME=VALUE` of --start as {NAME: value} (values read as YAML scalars)."""
    import yaml

    from twmr.tuning import TuneError

    point: dict[str, object] = {}
    for part in text.split(","):
        name, sep, value = part.partition("=")
        if not sep or not name.strip():
            raise TuneError(f"--start {text!r}: '{part}' is not NAME=VALUE. Fix: write "
                            f"--start 'ctrl.k=20,ctrl.phi=0.2' (every --param once).")
        point[name.strip()] = yaml.safe_load(value)
    return point


def cmd_tune(args: argparse.Namespace) -> int:
    from twmr import api

    metrics = [m.strip() for m in ",".join(args.metrics).split(",") if m.strip()]
    outcome = api.tune(args.scenario, args.param, args.objective, vary=args.vary,
                       realisations=args.realisations, trials=args.trials, seed=args.seed,
                       aggregate=args.aggregate, constraints=args.constraint, metrics=metrics,
                       overrides=args.set, method=args.method, out=args.out,
                       workers=args.workers, scheduler=args.scheduler, batch=args.batch,
                       lockstep=args.lockstep,
                       baseline=args.baseline, start=[_start_point(t) for t in args.start],
                       validation=args.validation, validate_top=args.validate_top,
                       test=args.test,
                       progress=not args.quiet)
    best = outcome.best
    if outcome.trials and all(t["status"] == "failed" for t in outcome.trials):
        from twmr.tuning import TuneError

        raise TuneError(f"every trial failed; the first's error: {outcome.trials[0]['error']} "
                        f"(all are in {outcome.folder}/realisations.parquet)")
    names = [p.partition("=")[0].strip() for p in args.param]
    held = "".join(f", {part} {best[f'{part}_objective']:.6g}" for part in ("validation", "test")
                   if best is not None and f"{part}_objective" in best)
    gap = f" (gap {best['gap']:+.3g})" if best is not None and "gap" in best else ""
    found = "no feasible trial" if best is None else (
        f"best trial {best['trial']}: objective {best['objective']:.6g} (spread "
        f"{best['spread']:.3g}){held}{gap} at " + ", ".join(f"{n}={best[n]}" for n in names))
    log.info("tune: %d trial(s) run now, %d in all; %s -> %s/", outcome.ran,
             len(outcome.trials), found, outcome.folder)
    return 0


def cmd_sweep_report(args: argparse.Namespace) -> int:
    from twmr.sweeps.report import sweep_report

    for written in sweep_report(Path(args.folder), Path(args.out) if args.out else None):
        print(written)
    return 0


def _parse_set(text: str) -> tuple[str, Any]:
    import yaml

    key, sep, value = text.partition("=")
    if not sep:
        raise CosimError(f"--set {text!r}: expected name=value. Fix: e.g. --set k=2.0")
    try:
        return key.strip(), yaml.safe_load(value)
    except yaml.YAMLError as err:
        problem = getattr(err, "problem", None) or "it does not parse"
        raise CosimError(f"--set {text!r}: the value {value!r} is not a YAML value ({problem}). "
                         f"Fix: close the bracket or quote, e.g. --set k=[1, 2] or "
                         f"--set 'name=\"text\"'.") from None


def _common() -> argparse.ArgumentParser:
    """Options every subcommand accepts, before or after its name."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show tracebacks and debug messages")
    common.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS,
                        help="debug messages")
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                        help="warnings and errors only; no progress bar")
    return common


#: the subcommands defined here; any other is an installed package's (`twmr.commands`)
BUILT_IN = ("run", "check", "components", "plot", "sweep", "tune", "sweep-report", "inspect",
            "export", "fmu")


def parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser; the installed packages' subcommands are added (their modules
    imported) unless `argv` names a built-in one."""
    common = _common()
    p = argparse.ArgumentParser(prog="twmr", parents=[common],
                                description="Co-simulation of wheeled mobile robots.")
    p.add_argument("--version", action="version", version=f"twmr-cosim {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    def with_set(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override: comp.param=value, comp.step_multiple=m, "
                             "experiment.stop|step|algorithm=value (repeatable)")

    r = sub.add_parser("run", parents=[common],
                       help="run a scenario; save results, summary and plots")
    r.add_argument("scenario")
    with_set(r)
    r.add_argument("--out", help="output directory (default results/<scenario name>)")
    r.add_argument("--plot", action="store_true", help="write PNG plots of the recorded signals")
    r.add_argument("--format", default="none",
                   help="exports beside result.arrows (the result itself, readable by twmr "
                        "plot and twmr.read_result), a comma list of registered result "
                        "formats (csv, mat, parquet, or an installed one) or none (default)")
    r.add_argument("--metrics", action="append", default=[], metavar="NAME",
                   help="registered metric sets to compute (e.g. tracking); repeatable")
    r.add_argument("--realtime", nargs="?", const="true", metavar="FACTOR",
                   help="pace steps to the wall clock (automatic with hardware components); a "
                        "FACTOR runs that much faster than it (2) or slower (0.25)")
    r.add_argument("--compiled", choices=("auto", "on", "off"),
                   help="compile the step loop with numba: auto (default: when every block "
                        "offers a kernel and the run has >= 10000 steps), on (an error "
                        "otherwise), off (the Python loop); default TWMR_COMPILED, else auto")
    r.add_argument("--live", metavar="[HOST:]PORT",
                   help="serve live scopes of the recorded signals in the browser while the run "
                        "goes (host 127.0.0.1 unless given; port 0: a free one, printed)")
    r.add_argument("--foxglove", metavar="[HOST:]PORT",
                   help="publish the recorded signals live to Foxglove (a Foxglove WebSocket "
                        "server; host 127.0.0.1 unless given; needs foxglove-sdk)")
    r.add_argument("--live-keep", action="store_true",
                   help="with --live: keep serving after the run, until Ctrl-C")
    r.add_argument("--fmu-log", action="store_true",
                   help="show every message the FMUs log (errors and warnings always show)")
    r.set_defaults(fn=cmd_run)
    c = sub.add_parser("check", parents=[common],
                       help="validate a scenario and print its graph, order and units")
    c.add_argument("scenario")
    with_set(c)
    c.add_argument("--schedule", action="store_true", help="print the generated step loop")
    c.add_argument("--trust-code", action="store_true",
                   help="import the scenario's own Python blocks to check them (importing runs "
                   "their code; without it they are refused)")
    c.set_defaults(fn=cmd_check)
    dg = sub.add_parser("diagram", parents=[common],
                        help="draw a scenario as SVG: blocks, ports with units, wires, step "
                        "order, subsystems, algebraic loops")
    dg.add_argument("scenario")
    with_set(dg)
    dg.add_argument("--out", help="the SVG file (default: the scenario's name, .svg)")
    dg.add_argument("--closed", action="append", metavar="SUBSYSTEM",
                    help="draw this subsystem as one block, its ports those its wires cross "
                    "(repeatable; all: every outermost one)")
    dg.add_argument("--trust-code", action="store_true",
                    help="import the scenario's own Python blocks to draw them (importing runs "
                    "their code; without it they are refused)")
    dg.set_defaults(fn=cmd_diagram)
    k = sub.add_parser("components", parents=[common],
                       help="list component kinds with ports, parameters, units")
    k.add_argument("kinds", nargs="*")
    k.add_argument("--trust-code", action="store_true",
                   help="import the scenario's own Python blocks to check them (importing runs "
                   "their code; without it they are refused)")
    k.set_defaults(fn=cmd_components)
    pl = sub.add_parser("plot", parents=[common],
                        help="plot a result (folder, .arrows, .csv, .mat or .parquet)")
    pl.add_argument("result", nargs="+", help="one result, or several to overlay")
    pl.add_argument("--signals", help="what to draw, one panel per signal ('a,b'; a vector "
                    "port stands for its elements; 'a+b' in one panel): one figure, "
                    "overlay.png, with every result in it")
    pl.add_argument("--out")
    pl.set_defaults(fn=cmd_plot)
    fi = sub.add_parser("fit", parents=[common],
                        help="estimate parameters and initial states so that runs match "
                        "measured signals (least squares, confidence intervals)")
    fi.add_argument("scenario")
    fi.add_argument("--data", action="append", required=True, metavar="RUN_OR_FILE",
                    help="measured data: a run's folder or a result file (CSV, Parquet, .mat); "
                    "repeat for several experiments (a run folder brings its overrides)")
    fi.add_argument("--estimate", action="append", required=True, metavar="NAME=LO:HI[@START]",
                    help="a parameter or initial-state element to estimate within LO..HI "
                    "(repeatable), e.g. plant.scale=0.5:2")
    fi.add_argument("--match", action="append", required=True, metavar="SIGNALS",
                    help="model signals to match, comma-separated; MODEL=COLUMN for a data "
                    "column of another name")
    fi.add_argument("--sigma", action="append", default=[], metavar="NAME=VALUE",
                    help="a signal's measurement standard deviation (default: the data's)")
    fi.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="override for every run (repeatable)")
    fi.add_argument("--until", type=float, help="fit the data up to this time [s] only, each "
                    "run stopped there")
    fi.add_argument("--max-runs", type=int, default=200, help="at most this many runs (per "
                    "local fit)")
    fi.add_argument("--starts", type=int, default=1, help="a global start: local fits from "
                    "the start values and from STARTS - 1 points of a Latin hypercube over the "
                    "bounds, the lowest cost kept (default 1)")
    fi.add_argument("--seed", type=int, default=0, help="seed of the global start's points")
    fit_where = fi.add_mutually_exclusive_group()
    fit_where.add_argument("--workers", type=int, help="the local fits on a Dask cluster of "
                           "this many local worker processes")
    fit_where.add_argument("--scheduler", metavar="ADDRESS", help="the local fits on the Dask "
                           "cluster at ADDRESS")
    fi.add_argument("--out", help="folder of the fit (default fits/<scenario>); a fit asked "
                    "again there resumes")
    fi.set_defaults(fn=cmd_fit)
    li = sub.add_parser("linearize", parents=[common],
                        help="the linear model (A, B, C, D) of a scenario around a point of its "
                        "run; Bode plot, poles, margins of a loop broken at a wire")
    li.add_argument("scenario")
    li.add_argument("--input", action="append", default=[], metavar="COMP.PORT",
                    help="a scalar port perturbed at its wire (repeatable)")
    li.add_argument("--output", action="append", default=[], metavar="COMP.PORT",
                    help="a port whose response is measured (repeatable)")
    li.add_argument("--loop", metavar="COMP.PORT", help="break the loop at this input's wire: "
                    "its loop transfer and margins")
    li.add_argument("--at", type=_time_or_steady, metavar="T|steady",
                    help="the point: a time of the run [s], or 'steady': the trim point the "
                    "run settles at with its inputs (set them with --set)")
    li.add_argument("--trim", action="append", default=[], metavar="COMP.NAME",
                    help="the point: the equilibrium at the start, stable or not, solved for "
                    "these start values (states or parameters; repeatable or by commas)")
    li.add_argument("--trim-output", action="append", default=[], metavar="COMP.PORT",
                    help="outputs held still at the trim point (default: every real output "
                    "of the scenario)")
    li.add_argument("--horizon", type=int, default=200, help="steps of impulse response "
                    "(default 200)")
    li.add_argument("--amplitude", type=float, default=1e-3, help="height of the pulse, in "
                    "the input's unit (default 1e-3)")
    li.add_argument("--order", type=int, help="states of the model (default: from the Hankel "
                    "singular values)")
    li.add_argument("--tol", type=float, default=1e-7, help="relative Hankel singular value "
                    "below which a state is dropped")
    li.add_argument("--fmu", metavar="COMP", help="the continuous model of the FMU COMP "
                    "(model exchange or co-simulation) at --at by its own derivatives (every "
                    "state, its real inputs and outputs)")
    li.add_argument("--derivatives", choices=("auto", "directional", "adjoint"),
                    default="auto", help="--fmu: by directional derivatives (a column per "
                    "state and input), adjoint ones (FMI 3.0: a row per rate and output), or "
                    "auto: directional where the FMU gives them")
    li.add_argument("--design", choices=("lqg", "lqi", "place"), help="design an "
                    "output-feedback controller on the model (controller.yaml, design.json); "
                    "lqi: lqg with an integrator per output")
    li.add_argument("--integral-weight", type=float, default=1.0, metavar="QI",
                    help="lqi: weight on the outputs' integrals (default 1)")
    li.add_argument("--output-weight", type=float, default=1.0, metavar="Q",
                    help="lqg: weight on the outputs (default 1)")
    li.add_argument("--input-weight", type=float, default=1.0, metavar="R",
                    help="lqg: weight on the inputs (default 1)")
    li.add_argument("--process-noise", type=float, default=1.0, metavar="W",
                    help="lqg: noise intensity at the inputs (default 1)")
    li.add_argument("--measurement-noise", type=float, default=1.0, metavar="V",
                    help="lqg: noise intensity on the outputs (default 1)")
    li.add_argument("--poles", default="", help="place: the regulator's discrete poles, "
                    "comma-separated (one per state; complex as 0.9+0.1j)")
    li.add_argument("--observer-poles", default="", help="place: the estimator's poles")
    li.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    li.add_argument("--out", help="folder of the model and plots (default linear/<scenario>)")
    li.set_defaults(fn=cmd_linearize)
    an = sub.add_parser("analyze", parents=[common],
                        help="a linear model twmr linearize saved: poles, zeros, ranks, step "
                        "response, margins of its loop; Bode, step and Nyquist figures")
    an.add_argument("folder", help="the folder twmr linearize --out wrote (linear.json, "
                    "linear.npz)")
    an.add_argument("--out", help="folder of the figures (default: the model's folder)")
    an.set_defaults(fn=cmd_analyze)
    ve = sub.add_parser("verify", parents=[common],
                        help="check a run against a reference within tolerance tubes (exit 1 "
                        "when a signal leaves its tube)")
    ve.add_argument("run", help="the run's folder or a result file")
    ve.add_argument("--reference", required=True, help="the reference: a run's folder, a "
                    "result file, or a CSV ('name [unit]' headers or units.json beside it)")
    ve.add_argument("--signals", action="append", default=[], metavar="NAMES",
                    help="signals to check, comma-separated (default: every one both have)")
    ve.add_argument("--abs", type=float, default=0.0, help="absolute tolerance, in each "
                    "signal's unit (default 0)")
    ve.add_argument("--rel", type=float, default=1e-3, help="tolerance relative to the "
                    "reference's magnitude (default 1e-3)")
    ve.add_argument("--shift", type=float, default=0.0, help="time tolerance [s]: the tube "
                    "spans the reference over t +- shift (default 0)")
    ve.add_argument("--plot", metavar="FILE", help="write the tubes and the run as FILE.png "
                    "and FILE.svg")
    ve.set_defaults(fn=cmd_verify)
    sw = sub.add_parser("sweep", parents=[common],
                        help="run a scenario over varied parameters (Monte Carlo) on Dask")
    sw.add_argument("scenario", help="the scenario, or a sweep file (YAML with vary:)")
    sw.add_argument("--vary", action="append", default=[], metavar="NAME=SPEC",
                    help="NAME (an override, e.g. plant.scale or plant.pose[1]) and SPEC: "
                         "uniform:LO:HI, normal:MU:SIGMA, values:A,B,C or grid:LO:HI:N "
                         "(repeatable)")
    sw.add_argument("--samples", type=int, help="number of runs (random, lhs); default 20")
    sw.add_argument("--method", choices=("random", "lhs", "grid"),
                    help="sampling: random draws, Latin hypercube, or the full grid")
    sw.add_argument("--seed", type=int, help="seed of the draws (default 0)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int,
                       help="local Dask worker processes (default: the cores)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="an existing Dask cluster you trust (it runs code here), e.g. "
                            "tls://host:8786; never read from a sweep file")
    sw.add_argument("--dashboard", action="store_true",
                    help="serve the local cluster's Dask dashboard on 127.0.0.1 (its address "
                         "is logged)")
    sw.add_argument("--out", help="folder of runs.parquet (default sweeps/<scenario name>)")
    sw.add_argument("--metrics", action="append", default=[], metavar="NAME",
                    help="registered metric sets per run (e.g. tracking); repeatable")
    sw.add_argument("--keep-signals", action="store_true",
                    help="keep each run's signals in <out>/runs/<run id>/")
    with_set(sw)
    sw.set_defaults(fn=cmd_sweep)
    tu = sub.add_parser("tune", parents=[common],
                        help="tune a scenario's parameters over fixed realisations (Optuna)")
    tu.add_argument("scenario")
    tu.add_argument("--param", action="append", default=[], metavar="NAME=SPEC",
                    help="a tuned override and its range: LO:HI, log:LO:HI, int:LO:HI or "
                         "values:A,B,C (repeatable)")
    tu.add_argument("--objective", required=True, metavar="EXPR",
                    help="expression of metric figures to minimise, e.g. 'mse_x + mse_y'")
    tu.add_argument("--aggregate", default="mean",
                    help="over the realisations: mean (default), median, max or qP (e.g. q0.9)")
    tu.add_argument("--constraint", action="append", default=[], metavar="EXPR<=BOUND",
                    help="to hold in every realisation, e.g. 'peak_error_x<=0.2' (repeatable)")
    tu.add_argument("--vary", action="append", default=[], metavar="NAME=SPEC",
                    help="what differs between realisations, as in `twmr sweep` (repeatable)")
    tu.add_argument("--realisations", type=int, default=1,
                    help="runs per trial, drawn once from --seed (default 1)")
    tu.add_argument("--method", choices=("random", "lhs"), default="random",
                    help="how the realisations are drawn")
    tu.add_argument("--trials", type=int, default=30,
                    help="trials of the study in all (a folder holding fewer continues)")
    tu.add_argument("--seed", type=int, default=0, help="seed of the draws and the sampler")
    tu.add_argument("--metrics", action="append", default=[], metavar="NAME",
                    help="metric sets per run (default: the registered sets that give the "
                         "figures of --objective and --constraint); repeatable")
    tune_where = tu.add_mutually_exclusive_group()
    tune_where.add_argument("--workers", type=int, default=1,
                            help="1 (default): runs in this process; more: local Dask workers")
    tune_where.add_argument("--scheduler", metavar="ADDRESS",
                            help="an existing Dask cluster you trust (it runs code here)")
    tu.add_argument("--batch", type=int, metavar="B",
                    help="trials asked and run together (default: the workers)")
    tu.add_argument("--lockstep", action="store_true",
                    help="ask a batch only once the one before is told (as tunes did before "
                         "the next batch was asked while one runs; slower on a cluster)")
    tu.add_argument("--start", action="append", default=[], metavar="NAME=VALUE,...",
                    help="a point tried first (every --param once); repeatable, in order")
    tu.add_argument("--validation", type=int, default=0, metavar="N",
                    help="N realisations drawn apart from the training ones and never optimised "
                         "on: the best trials (--validate-top) run on them and the best is chosen "
                         "there (0: chosen on the training realisations)")
    tu.add_argument("--validate-top", type=int, default=5, metavar="K",
                    help="how many of the best training trials run on the validation "
                         "realisations (default 5)")
    tu.add_argument("--test", type=int, default=0, metavar="N",
                    help="N further realisations the chosen trial runs on, reported only")
    tu.add_argument("--baseline", metavar="SCENARIO",
                    help="run once over the same realisations; its figures are base_<figure>")
    tu.add_argument("--out", help="the tune's folder (default tunes/<scenario name>)")
    with_set(tu)
    tu.set_defaults(fn=cmd_tune)
    sr = sub.add_parser("sweep-report", parents=[common],
                        help="summary table and plots of a sweep folder")
    sr.add_argument("folder")
    sr.add_argument("--out", help="where the report goes (default <folder>/report)")
    sr.set_defaults(fn=cmd_sweep_report)
    i = sub.add_parser("inspect", parents=[common], help="describe an FMU as a component, or "
                       "what an SSP is read as")
    i.add_argument("fmu")
    i.add_argument("--json", action="store_true",
                   help="print the interface (ports: name, causality, type, unit, size) as JSON")
    i.add_argument("--trust-code", action="store_true",
                   help="import the scenario's own Python blocks to check them (importing runs "
                   "their code; without it they are refused)")
    i.set_defaults(fn=cmd_inspect)
    e = sub.add_parser("export", parents=[common],
                       help="export a component kind as a standalone C FMU (co-simulation), "
                            "or a scenario as an SSP archive of FMUs")
    e.add_argument("kind", help="a kind (-> .fmu), or a scenario file (-> .ssp)")
    e.add_argument("-o", "--out", help="the .fmu file (default fmus/<kind>.fmu); for a "
                                       "scenario the .ssp file (default <scenario name>.ssp)")
    e.add_argument("--ssp", type=int, choices=(1, 2), default=None,
                   help="SSP version of a scenario's archive (default 1)")
    e.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version of the FMU (default 2)")
    e.add_argument("--python", action="store_true",
                   help="a pythonfmu FMU running the Python component (FMI 2.0; needs "
                        "twmr-cosim where it runs): for kinds without a C kernel")
    e.add_argument("--can", metavar="PROTOCOL",
                   help="a controller (asmc, smc) as an FMI-LS-BUS CAN node hosting two drives "
                        "of this protocol (odrive | cia402; FMI 3.0): wheel speeds from their "
                        "encoder frames, torques sent as their frames (docs/export.md)")
    with_set(e)
    e.set_defaults(fn=cmd_export)
    fm = sub.add_parser("fmu", parents=[common], help="work on an FMU file (build)")
    fmu_sub = fm.add_subparsers(dest="fmu_command", required=True)
    fb = fmu_sub.add_parser("build", parents=[common],
                            help="build a source-only FMU for this platform (this runs the "
                                 "FMU's code: its sources are compiled here)")
    fb.add_argument("fmu")
    fb.add_argument("--out", help="the built FMU (default <name>.<platform>.fmu beside it)")
    fb.add_argument("--timeout", type=float, metavar="SECONDS",
                    help="the longest the build may take (default 120)")
    fb.set_defaults(fn=cmd_fmu_build)
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    if words and words[0] in BUILT_IN:
        return p
    from twmr.registry import command, commands

    for name in commands():
        try:
            register: Any = command(name)  # register(subparsers, common options)
            register(sub, common)
        except ImportError as err:
            sp = sub.add_parser(name, parents=[common], help=f"(unavailable: {err})")
            sp.set_defaults(fn=_unavailable(name, err))
    return p


def _unavailable(name: str, err: ImportError) -> Any:
    def fn(args: argparse.Namespace) -> int:
        raise CosimError(f"'twmr {name}' cannot load ({err}). Fix: install what it needs, e.g. "
                         f"pip install 'twmr-cosim[hw]'.")
    return fn


def _configure_logging(args: argparse.Namespace) -> None:
    level = logging.INFO
    if getattr(args, "quiet", False):
        level = logging.WARNING
    if getattr(args, "verbose", False) or getattr(args, "debug", False):
        level = logging.DEBUG
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    log.handlers[:] = [handler]
    log.setLevel(level)
    log.propagate = False


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = parser(argv).parse_args(argv)
    except KeyboardInterrupt:
        return _interrupted_at_start()
    args.quiet = getattr(args, "quiet", False)
    args.debug = getattr(args, "debug", False)
    _configure_logging(args)
    t0 = time.perf_counter()
    try:
        from twmr.scenario.kinds import inspecting

        guard = inspecting(args.trust_code) if hasattr(args, "trust_code") else \
            contextlib.nullcontext()
        with guard:
            return int(args.fn(args) or 0)
    except CosimError as err:
        if args.debug:
            raise
        log.error("error: %s%s", err, _where(err))
        return 1
    except ImportError as err:
        from twmr.core.extras import missing

        error = missing(err, f"twmr {args.command}")
        if error is None or args.debug:
            raise
        log.error("error: %s", error)
        return 1
    except BrokenPipeError:
        _quiet_stdout()  # the reader went away (`twmr ... | head`): stop without a word
        return 141
    except OSError as err:
        if args.debug:
            raise
        what = f" '{err.filename}'" if err.filename else ""
        log.error("error: %s%s%s. Fix: check the path, its permissions and the free disk "
                  "space.", err.strerror or err, what, _where(err))
        return 1
    except KeyboardInterrupt as err:
        _ignore_stop_signals()  # a second Ctrl-C while the process ends changes nothing
        _forget_interrupt_in_exec()
        how = getattr(err, "signal_name", "SIGINT")
        log.error("interrupted (%s) after %.1f s%s", "Ctrl-C" if how == "SIGINT" else how,
                  time.perf_counter() - t0, _where(err) or ".")
        return 130 if how == "SIGINT" else 128 + _signal_number(how)


def _ignore_stop_signals() -> None:
    import signal

    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)


def _forget_interrupt_in_exec() -> None:
    """Exit with the status returned, not by SIGINT. CPython marks the process to end by SIGINT
    when a KeyboardInterrupt leaves code run by `exec` of a text (dataclasses and namedtuples
    make their methods so), even when it is caught later, and `python -m twmr.cli` obeys that
    mark at exit; a text run without one clears it."""
    exec("")  # noqa: S102 - an empty text


def _quiet_stdout() -> None:
    import os

    with contextlib.suppress(OSError, ValueError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _where(err: BaseException) -> str:
    folder = getattr(err, "partial_results", None)
    return f" (the results so far are in {folder}/)" if folder is not None else ""


def _signal_number(name: str) -> int:
    import signal

    return int(getattr(signal, name, signal.SIGTERM))


if __name__ == "__main__":
    sys.exit(main())
