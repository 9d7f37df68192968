"""Kinds a user writes: 'path/to/file.py:ClassName' (relative to the scenario's folder) and
'package.module:ClassName', each naming a `Component` subclass.

A file is imported once per process, as a module named after its resolved path
(`twmr_user_<stem>_<hash>`), so two scenarios with different `my_block.py` files do not collide
and a sweep worker that rebuilds the scenario from its text and folder imports the same file
under the same name (the compiled loop imports the block's kernels by that name). Importing a
file runs its code, as `import` does. Every failure is a `KindError`: what is wrong (the file or
module, the class, the line of the user's code at fault) and how to fix it.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import os
import re
import sys
import traceback
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path
from types import ModuleType

from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.registry import suggest

_MODULE = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")
_DOCS = "see docs/components.md"


class KindError(CosimError):
    """A kind that names a file, module or class that cannot be used: `message` (what is wrong)
    and `fix` (what to do)."""

    def __init__(self, message: str, fix: str = ""):
        self.message = message
        self.fix = fix
        super().__init__(f"{message} Fix: {fix}" if fix else message)

    def __reduce__(self) -> tuple:
        return (type(self), (self.message, self.fix))


def load_kind(kind: str, base_dir: Path | None = None) -> type[Component]:
    """The Component subclass `kind` names; a relative file path starts at `base_dir` (default:
    the working folder). KindError otherwise."""
    target, _, name = kind.rpartition(":")
    target, name = target.strip(), name.strip()
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    is_file = target.endswith(".py") or "/" in target or "\\" in target
    if not name.isidentifier():
        example = target if target else "my_block.py"
        raise KindError(f"the kind '{kind}' names no class after ':'.",
                        f"write the class name after the colon, e.g. '{example}:MyBlock'.")
    if is_file:
        _trusted_file(kind, target, base)
        module, where = _import_file(kind, target, base), f"the file '{target}'"
    elif _MODULE.match(target):
        _trusted_module(kind, target, name, base)
        module, where = _import_module(kind, target, name, base), f"the module '{target}'"
    else:
        raise KindError(f"the kind '{kind}': '{target}' is neither a Python file (ending in "
                        f".py) nor a module name (package.module).",
                        f"write 'path/to/file.py:{name}' (relative to the scenario's folder) "
                        f"or 'package.module:{name}'.")
    return _component_class(module, name, where)


#: folders (os.pathsep-separated) and module names beyond the scenario's own folder tree whose
#: code a scenario may run; '*' allows any (docs/security.md)
ALLOW_CODE = "TWMR_ALLOW_CODE"


def _allowed() -> list[str]:
    return [a for a in os.environ.get(ALLOW_CODE, "").split(os.pathsep) if a.strip()]


@contextlib.contextmanager
def inspecting(trust_code: bool = False) -> Iterator[None]:
    """While inside, a scenario is being inspected (`twmr check`, `inspect`, `components`):
    user code is not imported unless `trust_code` (--trust-code)."""
    token = _INSPECTING.set(not trust_code)
    try:
        yield
    finally:
        _INSPECTING.reset(token)


def _inspecting_refused(kind: str) -> None:
    if _INSPECTING.get():
        raise KindError(f"the kind '{kind}' is user code: inspecting the scenario would import "
                        f"it, and importing runs it.", "read the file first, then inspect with "
                        "--trust-code (twmr check --trust-code ...), or run the scenario.")


def _trusted_file(kind: str, target: str, base: Path) -> None:
    """Refuse a file outside the scenario's folder tree unless TWMR_ALLOW_CODE allows it."""
    _inspecting_refused(kind)
    path = (base / Path(target).expanduser()).resolve()
    roots = [base.resolve(), *(Path(a).expanduser().resolve() for a in _allowed() if a != "*")]
    if "*" in _allowed() or any(path.is_relative_to(r) for r in roots):
        return
    raise KindError(f"the kind '{kind}' names '{path}', outside the scenario's folder "
                    f"({base.resolve()}); a scenario runs only code from its own folder tree.",
                    f"move the file beside the scenario, or allow its folder: "
                    f"{ALLOW_CODE}={path.parent} (several separated by '{os.pathsep}').")


def _trusted_module(kind: str, target: str, name: str, base: Path) -> None:
    """Refuse a module that is not ours unless TWMR_ALLOW_CODE names it (or its package):
    installed blocks are registered by name (entry points) instead."""
    if target == "twmr" or target.startswith("twmr."):
        return
    _inspecting_refused(kind)
    allowed = _allowed()
    if "*" in allowed or any(target == a or target.startswith(f"{a}.") for a in allowed):
        return
    local = base / f"{target.replace('.', '/')}.py"
    hint = f" (did you mean the file '{target.replace('.', '/')}.py:{name}'?)" \
        if local.is_file() else ""
    raise KindError(f"the kind '{kind}' imports the module '{target}'{hint}; a scenario imports "
                    f"only files in its own folder tree and blocks installed by name.",
                    f"use the name the package registers ({_DOCS}), or allow the module: "
                    f"{ALLOW_CODE}={target.split('.')[0]}.")


#: True while `twmr check`, `inspect` or `components` reads a scenario without --trust-code
_INSPECTING: ContextVar[bool] = ContextVar("twmr_inspecting", default=False)


def _component_class(module: ModuleType, name: str, where: str) -> type[Component]:
    obj = getattr(module, name, None)
    classes = [n for n, v in vars(module).items() if isinstance(v, type)
               and issubclass(v, Component) and v.__module__ == module.__name__]
    if obj is None:
        known = classes or [n for n in vars(module) if not n.startswith("_")]
        fix = f"use one of the Component classes it defines: {', '.join(classes)}." if classes \
            else f"define `class {name}(Component):` in it ({_DOCS})."
        raise KindError(f"{where} defines no class '{name}'{suggest(name, known)}.", fix)
    if not (isinstance(obj, type) and issubclass(obj, Component)):
        what = "a class not derived from twmr.core.Component" if isinstance(obj, type) else \
            f"a {type(obj).__name__}, not a class"
        raise KindError(f"'{name}' in {where} is {what}, so it cannot be a component.",
                        f"derive it from Component: `from twmr.core import Component` and "
                        f"`class {name}(Component):` ({_DOCS}).")
    return obj


def module_name(path: Path) -> str:
    """The module name a user file is imported as: its stem and a hash of its resolved path."""
    stem = re.sub(r"\W", "_", path.stem)
    return f"twmr_user_{stem}_{hashlib.sha256(str(path).encode()).hexdigest()[:12]}"


def _import_file(kind: str, target: str, base: Path) -> ModuleType:
    try:
        path = (base / Path(target).expanduser()).resolve()
        found = path.is_file()
    except (OSError, RuntimeError) as err:  # a symbolic-link loop, a name too long
        raise KindError(f"the file '{target}' cannot be read ({err}).",
                        "give the path of the block's Python file.") from None
    if not found:
        nearby = sorted(p.name for p in path.parent.glob("*.py")) if path.parent.is_dir() \
            else []
        raise KindError(f"the file '{path}' does not exist"
                        f"{suggest(path.name, nearby)}.",
                        f"give the block's Python file relative to the scenario's folder "
                        f"({base}) or as an absolute path, e.g. 'my_block.py:"
                        f"{kind.rpartition(':')[2].strip()}' for a file next to the scenario.")
    name = module_name(path)
    module = sys.modules.get(name)
    if module is not None:
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise KindError(f"the file '{path}' cannot be imported as Python.",
                        "give a Python source file ending in .py.")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # the file's own dataclasses and kernels find their module
    try:
        spec.loader.exec_module(module)
    except (Exception, SystemExit) as err:  # noqa: BLE001 - the user's code, at its file:line
        del sys.modules[name]
        raise code_failure(err, f"importing the file '{path}'", path) from None
    return module


def _import_module(kind: str, target: str, name: str, base: Path) -> ModuleType:
    try:
        return importlib.import_module(target)
    except ModuleNotFoundError as err:
        if not err.name or not (target == err.name or target.startswith(f"{err.name}.")):
            raise code_failure(err, f"importing the module '{target}'", _origin(target)) \
                from None
        local = base / f"{target.replace('.', '/')}.py"
        hint = f" (did you mean the file '{target.replace('.', '/')}.py:{name}'?)" \
            if local.is_file() else ""
        raise KindError(f"no module '{target}' can be imported{hint}.",
                        f"install the package that provides it (an installed package may "
                        f"register its kinds by name, {_DOCS}), or name a file: "
                        f"'path/to/file.py:{name}' relative to the scenario's folder.") from None
    except (Exception, SystemExit) as err:  # noqa: BLE001 - the module's code, at its file:line
        raise code_failure(err, f"importing the module '{target}'", _origin(target)) from None


def _origin(target: str) -> Path | None:
    """The file of module `target`, when it can be found without importing it."""
    try:
        spec = importlib.util.find_spec(target)
    except Exception:  # noqa: BLE001 - a parent package that fails to import
        return None
    return Path(spec.origin) if spec is not None and spec.origin else None


def code_failure(err: BaseException, doing: str, path: Path | None) -> KindError:
    """A KindError for user code that raised while `doing` (e.g. "importing the file 'x.py'"),
    naming the file and line at fault (the last frame in `path` when given, else the
    innermost)."""
    line = _line_of(err, path)
    cause = err.__cause__
    if isinstance(err, RuntimeError) and isinstance(cause, CosimError):
        err = cause  # Python 3.11 wraps the errors of a port's `__set_name__`
    if isinstance(err, CosimError):
        message, _, fix = str(err).partition(" Fix: ")
        return KindError(f"{doing} failed{line}: {message}", fix or "correct the code there.")
    if isinstance(err, SyntaxError):
        at = f"{err.filename}:{err.lineno}" if err.lineno else str(err.filename)
        return KindError(f"{doing} failed: a syntax error at {at}: {err.msg}.",
                         f"correct line {err.lineno} of {err.filename}.")
    if isinstance(err, SystemExit):
        return KindError(f"{doing} failed{line}: the code called exit ({err.code!r}), which "
                         f"would end twmr with nothing said.", "remove the exit from the "
                         "module's top level (guard it with `if __name__ == '__main__':`).")
    if isinstance(err, ModuleNotFoundError) and err.name:
        return KindError(f"{doing} failed{line}: no module named '{err.name}'.",
                         f"install the package that provides '{err.name}' "
                         f"(`python -m pip install ...` in the environment twmr runs in), or "
                         f"correct the import.")
    return KindError(f"{doing} failed{line}: {type(err).__name__}: {err}.",
                     "correct the code there.")


def _line_of(err: BaseException, path: Path | None) -> str:
    """' at file:line' of the frame in `path` (else the innermost) where `err` was raised."""
    frames = [f for f in traceback.extract_tb(err.__traceback__)
              if not f.filename.startswith("<frozen")]
    mine = [f for f in frames if path is not None and Path(f.filename) == path]
    if not (mine or frames):
        return ""
    frame = (mine or frames)[-1]
    return f" at {frame.filename}:{frame.lineno}"
