"""Component kinds, metrics and CLI subcommands by name, found through entry points.

Like python-can's interface registry: names map to ``module:attr`` strings and a module is
imported only when its entry is used, so robot analysis and hardware libraries load only when a
scenario or command needs them. A kind may also name a class directly ('my_block.py:MyBlock',
'package.module:MyBlock', see `lookup`). Groups: ``twmr.components`` (a `Component` subclass),
``twmr.metrics`` (a `twmr.metricset.MetricSet`, or a function `Result -> dict[str, float]`),
``twmr.commands`` (a function
`register(subparsers)` adding one or more subcommands), ``twmr.formats`` (result writers),
``twmr.algorithms`` (master algorithms), ``twmr.can_protocols`` (CAN drive links) and
``twmr.loaders`` (scenario file formats, by suffix); a block's C twin, for FMU export, is its
class's `c_twin`. `plugins(group)` lists any group and
`plugin(group, name, what)` loads one entry.
"""
from __future__ import annotations

import difflib
import importlib
import json
import os
import sys
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

GROUP = "twmr.components"
METRICS = "twmr.metrics"
COMMANDS = "twmr.commands"
FORMATS = "twmr.formats"
ALGORITHMS = "twmr.algorithms"
CAN_PROTOCOLS = "twmr.can_protocols"
#: readers of logs beside a run's results that a result format can add as channels, by suffix
FRAME_LOGS = "twmr.frame_logs"
#: scenario file formats by suffix without its dot: a function `Path -> ScenarioSpec`
LOADERS = "twmr.loaders"
#: readers of measured samples for the `data` block that need a database to decode them, by
#: the kind of source: a function `(path, database, columns) -> (columns, units, values)`
SAMPLE_READERS = "twmr.sample_readers"
GROUPS = (GROUP, METRICS, COMMANDS, FORMATS, ALGORITHMS, CAN_PROTOCOLS, FRAME_LOGS, LOADERS,
          SAMPLE_READERS)


@cache
def _group(group: str) -> dict[str, str]:
    if group in GROUPS:
        return _all_groups()[group]
    from importlib.metadata import entry_points

    return {ep.name: ep.value for ep in entry_points(group=group)}


def _cache_file() -> Path:
    """Where the entry points found last are kept (beside the compiled-loop cache)."""
    base = os.environ.get("TWMR_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(Path.home(), ".cache"), "twmr")
    return Path(base) / "entry_points.json"


def _environment() -> list[Any]:
    """What the installed distributions' entry points depend on: the metadata folders
    (`*.dist-info`, `*.egg-info`) in each folder of the import path, in its order, with their
    modification times (an install, upgrade or uninstall adds, replaces or removes one; a
    folder without any, such as the working folder, changes nothing)."""
    stamp: list[Any] = [sys.version]
    for entry in sys.path:
        folder = entry or "."
        try:
            names = sorted(n for n in os.listdir(folder)
                           if n.endswith((".dist-info", ".egg-info")))
            if names:
                stamp.append([os.path.abspath(folder),
                              [[n, os.stat(os.path.join(folder, n)).st_mtime_ns]
                               for n in names]])
        except OSError:
            continue
    return stamp


@cache
def _all_groups() -> dict[str, dict[str, str]]:
    """Every entry-point group of `GROUPS`: name -> 'module:attr', read from the installed
    distributions (importlib.metadata, tens of ms), or from the cache file written when they
    were last read in the same environment."""
    path, stamp = _cache_file(), _environment()
    try:
        saved = [e for e in json.loads(path.read_text()) if isinstance(e, dict)]
    except (OSError, ValueError, TypeError):
        saved = []
    for entry in saved:
        if entry.get("environment") == stamp and isinstance(entry.get("groups"), dict):
            return entry["groups"]
    from importlib.metadata import entry_points

    found = entry_points()
    groups = {group: {ep.name: ep.value for ep in found.select(group=group)}
              for group in GROUPS}
    try:  # the last few environments (each way of starting Python has its own sys.path[0])
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps([{"environment": stamp, "groups": groups}, *saved[:7]]))
        os.replace(tmp, path)
    except OSError:
        pass  # a cache that cannot be written is read anew next time
    return groups


def plugins(group: str) -> dict[str, str]:
    """Every entry of an entry-point group: name -> 'module:attr' (nothing is imported)."""
    return _group(group)


def plugin(group: str, name: str, what: str) -> Any:
    """The object registered as `name` in `group`; CosimError naming the known ones (`what`
    says what an entry is, e.g. 'result format')."""
    from twmr.core.errors import CosimError

    known = _group(group)
    target = known.get(name)
    if target is None:
        raise CosimError(f"unknown {what} '{name}'{suggest(name, known)}. Fix: use one of: "
                         f"{', '.join(sorted(known)) or '(none installed)'}.")
    return _resolve(target)


def kinds() -> dict[str, str]:
    """All known kinds: name -> 'module:Class'."""
    return _group(GROUP)


def metrics() -> dict[str, str]:
    """All registered metric sets: name -> 'module:function'."""
    return _group(METRICS)


def commands() -> dict[str, str]:
    """Subcommands registered by installed packages: name -> 'module:register'."""
    return _group(COMMANDS)


def suggest(name: str, choices: list[str] | tuple[str, ...] | set[str] | dict[str, Any]) -> str:
    """' (did you mean 'x'?)' for the closest choice, or ''."""
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _resolve(target: str) -> Any:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def lookup(kind: str, base_dir: Path | None = None) -> Any:
    """The Component class of `kind`: a registered name, 'path/to/file.py:Class' (relative to
    `base_dir`, default the working folder) or 'package.module:Class'. KeyError with a
    suggestion for an unknown name; `twmr.scenario.kinds.KindError` for a file, module or class
    that cannot be used."""
    target = kinds().get(kind)
    if target is None and ":" in kind:
        from twmr.scenario.kinds import load_kind

        return load_kind(kind, base_dir)
    if target is None:
        raise KeyError(
            f"unknown component kind '{kind}'{suggest(kind, kinds())}; "
            f"known kinds: {', '.join(sorted(kinds()))}"
        )
    return _resolve(target)


def metric_units(names: list[str]) -> dict[str, str]:
    """The unit of each figure of the metric sets `names` that declare them (a `units` mapping
    on the set); sets that are not installed are left out."""
    from twmr.core.errors import CosimError
    from twmr.metricset import metric_set

    units: dict[str, str] = {}
    for name in names:
        try:
            units.update(metric_set(metric(name)).units)
        except (CosimError, ImportError):
            continue
    return units


def sets_giving(figures: list[str]) -> list[str]:
    """The registered metric sets (by name, sorted) that give at least one of `figures` (a
    `base_` prefix, a baseline's figure, stripped), each figure by the first set that gives
    it."""
    from twmr.core.errors import CosimError
    from twmr.metricset import metric_set

    wanted = [f.removeprefix("base_") for f in figures]
    chosen: list[str] = []
    for name in sorted(metrics()):
        try:
            found = metric_set(metric(name))
        except (CosimError, ImportError):
            continue
        if any(found.gives(f) for f in wanted):
            chosen.append(name)
            wanted = [f for f in wanted if not found.gives(f)]
    return chosen


def metric(name: str) -> Callable[..., dict[str, Any]]:
    """The metric function registered as `name`; CosimError naming the known ones."""
    from twmr.core.errors import CosimError

    target = metrics().get(name)
    if target is None:
        raise CosimError(f"unknown metric set '{name}'{suggest(name, metrics())}. Fix: use one "
                         f"of: {', '.join(sorted(metrics())) or '(none installed)'}.")
    return _resolve(target)


def command(name: str) -> Callable[[Any], None]:
    """The `register(subparsers)` function of a registered subcommand."""
    return _resolve(commands()[name])
