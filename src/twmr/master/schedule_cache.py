"""The compiled loop's cache: each generated step loop as a module file, and numba's machine code
of it, both used only when their content is what was written.

- `schedule_<key>.py` (a scenario's generated loop) or `kind_<key>.py` (the adapters of one
  kind of block, `twmr.master.driver`); <key>: a hash of the generated source, the source files
  of the kernels' packages and numba's version. Before anything is imported, the file's text is
  compared with the source generated now; a file that differs (edited, truncated, a line
  prepended) is rewritten, with a log line. The module is executed from the generated source,
  never from the file: the file is there for numba, whose cache is keyed by it.
- numba's cache of it (`<module>.*.nbi` / `.nbc` in numba's cache folder: pickles, i.e. code).
  The SHA-256 of each of these files is recorded in `schedule_<key>.manifest.json` (written whole,
  then renamed) right after numba writes them; before numba reads them they are checked against
  it. A file that differs or is not recorded, or one numba cannot read, makes all of them go
  (logged) and numba compiles afresh. A lock file serialises the recording and the checking
  between processes (sweep workers compile at once).
"""
from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import importlib.metadata
import json
import logging
import os
import sys
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

log = logging.getLogger("twmr.run")
_NUMBA_SUFFIXES = (".nbi", ".nbc")


def load(source: str, names: dict[str, Any], folder: Path) -> tuple[Any, Any]:
    """(run, finish) of the generated loop `source` (`load_module`)."""
    module = load_module(source, names, folder, "schedule")
    return module.run, module.finish


def load_module(source: str, names: dict[str, Any], folder: Path, prefix: str
                ) -> types.ModuleType:
    """The generated `source` (which imports the kernels in `names`) as the module
    `<prefix>_<key>.py` in `folder`, with numba's cache of it verified. OSError when the folder
    cannot be written."""
    key = _key(source, names)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{prefix}_{key}.py"
    _ensure_text(path, source)
    modname = f"twmr_{prefix}_{key}"
    module = sys.modules.get(modname)
    if module is None:
        module = types.ModuleType(modname)
        module.__file__ = str(path)
        exec(compile(source, str(path), "exec"), module.__dict__)  # noqa: S102 - generated here
        sys.modules[modname] = module
        # every numba function of the module (the driver's adapters and helpers too)
        own = [v for v in vars(module).values() if hasattr(v, "_cache") and
               getattr(getattr(v, "py_func", None), "__module__", None) == modname]
        verified = _VerifiedCache(path, own)
        for fn in own:
            verified.wrap(fn._cache)
    return module


def _key(source: str, names: dict[str, Any]) -> str:
    """The hash naming the module of `source`: its text, numba's version and the source files
    of the kernels' packages (their modules and the sibling modules holding their helpers)."""
    digest = hashlib.sha256(source.encode())
    folders = {Path(f).parent for f in (getattr(sys.modules.get(fn.__module__), "__file__", None)
                                        for fn in names.values()) if f}
    digest.update(_packages(frozenset(folders)).encode())
    return digest.hexdigest()[:20]


@functools.cache
def _packages(folders: frozenset[Path]) -> str:
    """A hash of numba's version (read without importing numba) and of the source files in
    `folders`, once per process (the modules it holds are imported once too)."""
    digest = hashlib.sha256(importlib.metadata.version("numba").encode())
    for file in sorted(f for folder in folders for f in folder.glob("*.py")):
        digest.update(file.read_bytes())
    return digest.hexdigest()


def has_machine_code(source: str, names: dict[str, Any], folder: Path,
                     prefix: str = "schedule") -> bool:
    """Whether this process compiled the module of `source` (a numba function of it holds
    machine code) or `folder` holds the module and numba's cache of it (index files), i.e. a
    later `load_module` finds compiled code (unless the cache fails its check)."""
    stem = f"{prefix}_{_key(source, names)}"
    module = sys.modules.get(f"twmr_{stem}")
    if module is not None and any(getattr(v, "signatures", None) for v in vars(module).values()):
        return True
    return (folder / f"{stem}.py").is_file() and \
        any((folder / "__pycache__").glob(f"{stem}.*.nbi"))


def claim(source: str, names: dict[str, Any], folder: Path, prefix: str = "schedule"
          ) -> Any:
    """An open file holding the lock on compiling the module of `source` in `folder` (closing
    it, or the process ending, lets it go), or None when another process holds it (it is
    compiling that module: it will be in `folder` soon) or the folder cannot be written."""
    lock = folder / f".{prefix}_{_key(source, names)}.compiling"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        f = open(lock, "a")  # noqa: SIM115 - held by the caller until it has compiled
    except OSError:
        return None
    try:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        f.close()
        return None
    return f


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _ensure_text(path: Path, source: str) -> None:
    """`path` holds exactly `source` (written whole, then renamed, when it does not)."""
    expected = source.encode()
    try:
        found = path.read_bytes()
    except FileNotFoundError:
        found = None
    if found == expected:
        return
    if found is not None:
        log.warning("the cached compiled loop %s differs from the loop generated now "
                    "(SHA-256 %s, expected %s); rewriting it and compiling again", path,
                    _digest(found)[:12], _digest(expected)[:12])
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(expected)
    os.replace(tmp, path)


def quick_loader(cache: Any) -> Any:
    """numba's load of a cached overload without refreshing the target context first: the
    refresh imports every typing and lowering registry numba has (about 0.35 s on a first
    load), which machine code read back does not need, but for the symbols it links to that
    those imports register: the runtime's (NRT_*, `rtsys.initialize`) and the hash secrets
    (`numba.cpython.hashing`; numba's own C helpers come with the context, parallel code
    brings its own initialiser). A miss compiles, and numba's compiler refreshes the context
    itself (`CompilerBase`). numba's own `load_overload` where the cache has no such parts."""
    inner = getattr(cache, "_load_overload", None)
    guard = getattr(cache, "_guard_against_spurious_io_errors", None)
    if inner is None or guard is None:
        return cache.load_overload

    def load(sig: Any, target_context: Any) -> Any:
        import numba.cpython.hashing  # noqa: F401 - its import gives the hash secrets' symbols
        from numba.core.runtime import rtsys

        rtsys.initialize(target_context)  # the runtime's symbols (NRT_*) the code links to
        with guard():
            return inner(sig, target_context)
        return None  # the guard swallowed a spurious I/O error: compiled anew

    return load


class _VerifiedCache:
    """numba's cache files of one generated module, checked against the manifest before numba
    reads them and recorded in it after numba writes them."""

    def __init__(self, path: Path, dispatchers: list[Any]):
        self.path = path
        self.manifest = path.with_name(f"{path.stem}.manifest.json")
        self.lock = path.with_name(f".{path.stem}.lock")
        self.folders = {Path(d._cache.cache_path) for d in dispatchers
                        if getattr(d._cache, "cache_path", None)}

    def wrap(self, cache: Any) -> None:
        """Make `cache` (a dispatcher's numba cache) load and save through here."""
        load, save = quick_loader(cache), cache.save_overload

        def load_overload(sig: Any, target_context: Any) -> Any:
            with self._locked(fcntl.LOCK_SH):  # no process saves or purges while it is read
                bad = self._mismatch()
                if not bad:
                    try:
                        return load(sig, target_context)
                    except Exception as exc:  # noqa: BLE001 - unreadable: compiled anew
                        unreadable = f"numba could not read it ({type(exc).__name__}: {exc})"
            if bad:
                self._purge(bad, unless_mended=True)
            else:
                self._purge(unreadable, unless_mended=False)
            return None

        def save_overload(sig: Any, data: Any) -> None:
            with self._locked(fcntl.LOCK_EX):
                save(sig, data)
                self._record()

        cache.load_overload, cache.save_overload = load_overload, save_overload

    def _files(self) -> list[Path]:
        return sorted(f for folder in self.folders if folder.is_dir()
                      for f in folder.glob(f"{self.path.stem}.*") if f.suffix in _NUMBA_SUFFIXES)

    def _recorded(self) -> dict[str, str]:
        try:
            data = json.loads(self.manifest.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return {}
        files = data.get("files") if isinstance(data, dict) else None
        return files if isinstance(files, dict) else {}

    def _mismatch(self) -> str:
        """'' when every numba cache file is recorded with its hash, else what is wrong."""
        recorded = self._recorded()
        for file in self._files():
            digest = recorded.get(str(file))
            if digest is None:
                return f"{file.name} is not recorded in {self.manifest.name}"
            if digest != _digest(file.read_bytes()):
                return f"{file.name} differs from what was recorded when numba wrote it"
        return ""

    def _record(self) -> None:
        files = {str(f): _digest(f.read_bytes()) for f in self._files()}
        tmp = self.manifest.with_name(f".{self.manifest.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"module": self.path.name, "files": files}, indent=1) + "\n")
        os.replace(tmp, self.manifest)

    def _purge(self, why: str, unless_mended: bool) -> None:
        """Remove numba's files of the module and the manifest (`why` they are not used); with
        `unless_mended`, not if another process has recorded a consistent set meanwhile."""
        with self._locked(fcntl.LOCK_EX):
            if unless_mended and not self._mismatch():
                return
            log.warning("numba's cache of %s is not used: %s; compiling it again", self.path,
                        why)
            for file in self._files():
                file.unlink(missing_ok=True)
            self.manifest.unlink(missing_ok=True)

    @contextlib.contextmanager
    def _locked(self, how: int) -> Iterator[None]:
        with open(self.lock, "a") as f:
            fcntl.flock(f.fileno(), how)
            yield
