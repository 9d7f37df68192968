"""`kind: system`: another scenario file used as a block.

`parameters: {path: robot.yaml}` names the file (relative to the including file's folder); the
other parameters set values of the inner blocks by their path inside it (`plant.scale: 2`,
`drive.motor.torque_max: 40` through a nested subsystem), located where the including file
writes them. The inner file is read by the loader of its suffix, so it may include further
files; a file that includes itself, directly or through others, is refused naming the chain.
"""
from __future__ import annotations

import os
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.scenario.structure import MAX_DEPTH, MAX_INCLUSIONS, Given, ScenarioSpec

#: the files being included, outermost first, each with where its inclusion is written
_CHAIN: ContextVar[tuple[tuple[Path, Location], ...]] = ContextVar("twmr_include_chain",
                                                                  default=())
#: the inclusions read so far while one top-level scenario is loaded
_COUNT: ContextVar[list[int]] = ContextVar("twmr_include_count")


def subsystem(name: str, parameters: dict[str, Given[Any]], initial: dict[str, Given[Any]],
              where: Location, source: str, base_dir: Path) -> ScenarioSpec:
    """The structure of the file component `name` of `source` includes, with the values the
    including file sets applied. ScenarioError naming `source`:line when the path is missing,
    names no file, or closes a cycle of inclusion."""
    given = parameters.get("path")
    fix = f"give the file to include: 'parameters: {{path: robot.yaml}}' (relative to " \
          f"{base_dir})."
    if given is None or not isinstance(given.value, str) or not given.value.strip():
        raise ScenarioError(Problem(given.where if given else where, f"component '{name}' "
                                    f"(kind: system) names no scenario file to include.", fix))
    target = (base_dir / given.value).resolve()
    shown = _shown(source, given.value, target)
    chain = _CHAIN.get()
    if target in [path for path, _ in chain] or target == _resolved(source):
        steps = [f"{loc} includes {path.name}" for path, loc in chain[1:]]
        steps.append(f"{given.where} includes {target.name}")
        raise ScenarioError(Problem(given.where, f"component '{name}' includes '{shown}', which "
                                    f"is already being included, so the inclusion never ends: "
                                    f"{'; '.join(steps)}.", "remove the inclusion that closes "
                                    "the cycle: a file may not include itself, directly or "
                                    "through others."))
    if not target.is_file():
        what = "is a folder" if target.is_dir() else "is not a regular file" \
            if target.exists() else "does not exist"
        raise ScenarioError(Problem(given.where, f"component '{name}' (kind: system) includes "
                                    f"'{shown}', which {what} (path '{given.value}' is relative "
                                    f"to the including file's folder, {base_dir}).",
                                    "give the path of a scenario file, e.g. 'path: robot.yaml' "
                                    "for a file beside this one."))
    from twmr.scenario.loaders import load_structure
    from twmr.scenario.overrides import assign

    if not chain:
        _COUNT.set([0])
    count = _COUNT.get()
    count[0] += 1
    if count[0] > MAX_INCLUSIONS or len(chain) >= MAX_DEPTH:
        what = f"more than {MAX_INCLUSIONS:,} inclusions (a file included twice counts twice)" \
            if count[0] > MAX_INCLUSIONS else f"more than {MAX_DEPTH} files deep"
        raise ScenarioError(Problem(given.where, f"component '{name}' includes '{shown}': the "
                                    f"scenario reads {what}, which no system needs.",
                                    "include each part once and wire it where it is needed; a "
                                    "subsystem used many times can be one file with vector "
                                    "ports."))
    token = _CHAIN.set((*(chain or ((_resolved(source) or target, where),)),
                        (target, given.where)))
    try:
        inner = load_structure(Path(shown))
    except ScenarioError as err:  # which inclusion read it: the same file may be included twice
        at = f"{given.where.file}:{given.where.line}"
        raise type(err)([Problem(p.location, f"{p.message.rstrip('.')} (included as '{name}' "
                                 f"at {at}).", p.hint) for p in err.problems]) from None
    finally:
        _CHAIN.reset(token)
    problems: list[Problem] = []
    for key, value in (*parameters.items(), *initial.items()):
        if key == "path":
            continue
        comp, dot, var = key.rpartition(".")
        if not dot or not comp or not var:
            blocks = ", ".join(inner.components)
            problems.append(Problem(value.where, f"'{key}' of subsystem '{name}': a subsystem's "
                                    f"values are its blocks' values, named block.name.",
                                    f"write e.g. '{next(iter(inner.components))}.{key}: ...' "
                                    f"(its blocks: {blocks})."))
            continue
        inner = assign(inner, comp.split("."), var, value, problems, name)
    if problems:
        raise ScenarioError(problems)
    return inner


def _resolved(source: str) -> Path | None:
    """The file a scenario's source names, if it names one."""
    path = Path(source)
    return path.resolve() if not source.startswith("<") and path.is_file() else None


def _shown(source: str, relative: str, target: Path) -> str:
    """How messages name an included file: beside its includer's name when that leads to it."""
    beside = os.path.normpath(Path(source).parent / relative)
    return beside if not source.startswith("<") and Path(beside).resolve() == target \
        else str(target)
