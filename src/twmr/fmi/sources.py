"""Source-only FMUs: built for this platform only when the user asks, since building an FMU runs
its code (its sources, its build description) on this machine.

Two ways to ask: `compile: true` under the FMU component's parameters (built at each load, into a
scratch folder of this process) or `twmr fmu build X.fmu` (a copy of the FMU with the binary
added, which then runs with no opt-in). Without either, a source-only FMU is refused when loaded,
so at `twmr check`.

Before anything reaches a compiler, every file name the FMU gives is checked: the members of its
`sources/` folder, the source files named in modelDescription.xml (FMI 2, `<SourceFiles>`) or
`sources/buildDescription.xml` (FMI 3, `<SourceFile name=...>`), its include folders,
preprocessor definitions, language and model identifier. Only plain names pass
(`[A-Za-z0-9_.-]`, no path separator, no control character, no shell, CMake or Make syntax), and
source files must end in a C or C++ suffix. The sources are then compiled with the C compiler
directly ($CC, default cc; $CXX, default c++, for C++), with no build system, in a fresh scratch
folder holding only the FMU's `sources/`, each command with its arguments as a list (no shell),
within a timeout (default `DEFAULT_TIMEOUT`); a compiler that does not finish is killed with its
process group.
"""
from __future__ import annotations

import atexit
import functools
import hashlib
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.errors import FmuError

#: the longest a build of an FMU from its sources may take [s]
DEFAULT_TIMEOUT = 120.0
_C = (".c",)
_CXX = (".cc", ".cpp", ".cxx")
_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*\Z")
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_VALUE = re.compile(r"[A-Za-z0-9_.+-]*\Z")
_STANDARDS = {"C89": "c89", "C90": "c90", "C99": "c99", "C11": "c11", "C17": "c17",
              "C23": "c2x", "C++98": "c++98", "C++11": "c++11", "C++14": "c++14",
              "C++17": "c++17", "C++20": "c++20", "C++23": "c++2b"}
_FIX_NAMES = ("Fix: do not build or run this FMU unless its vendor explains the name; ask for "
              "an FMU whose source files have plain names, or a binary for this platform.")


def binary_folders(md: Any) -> tuple[str, ...]:
    """Names of the binaries folder for this platform: FMI 2 linux64, FMI 3 x86_64-linux (which
    fmpy's `supported_platforms` also reports as linux64)."""
    import fmpy

    return (fmpy.platform,) if md.fmiVersion == "2.0" else (fmpy.platform_tuple, fmpy.platform)


def has_binary(path: Path, md: Any) -> bool:
    import fmpy

    return bool(set(fmpy.supported_platforms(str(path))) & set(binary_folders(md)))


def has_sources(md: Any) -> bool:
    return bool(md.buildConfigurations and md.buildConfigurations[0].sourceFileSets)


def _missing_libraries(path: Path, md: Any) -> list[str]:
    """binaries/<platform>/<modelIdentifier><ext> the FMU lacks, for each interface it has."""
    import fmpy

    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
    ext = fmpy.sharedLibraryExtension
    wanted = {i.modelIdentifier for i in (md.coSimulation, md.modelExchange) if i is not None}
    return sorted(f"binaries/{binary_folders(md)[0]}/{ident}{ext}" for ident in wanted
                  if not any(f"binaries/{folder}/{ident}{ext}" in names
                             for folder in binary_folders(md)))


@dataclass
class BuildPlan:
    """What compiling an FMU takes, every name checked: its model identifier, the source files
    and include folders (plain names under sources/), `-D` definitions and `-std=` flags."""

    identifier: str
    sources: list[str]
    includes: list[str] = field(default_factory=list)
    definitions: list[str] = field(default_factory=list)
    standards: list[str] = field(default_factory=list)

    @property
    def cxx(self) -> bool:
        return any(s.endswith(_CXX) for s in self.sources)


def _shown(text: Any) -> str:
    shown = repr(text)
    return shown if len(shown) <= 90 else shown[:87] + "...'"


def _refuse(path: Path, instance: str, what: str) -> FmuError:
    return FmuError(instance, None, f"FMU '{path.name}': {what}; twmr hands nothing of this FMU "
                    f"to a compiler. {_FIX_NAMES}")


def build_plan(path: Path, md: Any, instance: str) -> BuildPlan:
    """The FMU's build, every name it gives checked (see the module's docstring); FmuError naming
    the first name that is not plain. Reads the FMU, runs nothing."""
    where = "modelDescription.xml" if md.fmiVersion == "2.0" else "sources/buildDescription.xml"
    with zipfile.ZipFile(path) as z:
        members = [n for n in z.namelist() if n.startswith("sources/")]
    for member in members:
        parts = member[len("sources/"):].rstrip("/").split("/")
        if member != "sources/" and not all(_PLAIN.match(p) for p in parts):
            raise _refuse(path, instance, f"its sources/ folder holds a file named "
                          f"{_shown(member)}, which is not a plain file name (letters, digits, "
                          f"'_', '.', '-' only)")
    files = {m[len("sources/"):] for m in members}
    iface = md.coSimulation or md.modelExchange
    config = md.buildConfigurations[0]
    identifier = config.modelIdentifier or iface.modelIdentifier
    if not _IDENTIFIER.match(str(identifier)):
        raise _refuse(path, instance, f"its model identifier {_shown(identifier)} is not a C "
                      f"identifier (as FMI requires)")
    plan = BuildPlan(identifier, [])
    for fileset in config.sourceFileSets:
        for name in fileset.sourceFiles:
            if not (isinstance(name, str) and _PLAIN.match(name) and name.endswith(_C + _CXX)):
                raise _refuse(path, instance, f"{where} names the source file {_shown(name)}, "
                              f"which is not a plain C or C++ file name (letters, digits, '_', "
                              f"'.', '-', ending in {', '.join(_C + _CXX)}; no path separator, "
                              f"control character, quote, ';' or '$')")
            if name not in files:
                raise FmuError(instance, None, f"FMU '{path.name}': {where} names the source "
                               f"file '{name}', which is not in its sources/ folder. Fix: ask "
                               f"the FMU's vendor for a complete FMU.")
            plan.sources.append(name)
        for folder in fileset.includeDirectories:
            if folder in (".", "./"):
                continue
            if not (isinstance(folder, str) and _PLAIN.match(folder)):
                raise _refuse(path, instance, f"{where} names the include folder "
                              f"{_shown(folder)}, which is not a plain folder name under sources/")
            plan.includes.append(folder)
        for d in fileset.preprocessorDefinitions:
            value = "" if d.value is None else str(d.value)
            if not (isinstance(d.name, str) and _IDENTIFIER.match(d.name) and
                    _VALUE.match(value)):
                raise _refuse(path, instance, f"{where} defines the preprocessor symbol "
                              f"{_shown(d.name)} = {_shown(value)}; only a C identifier set to "
                              f"letters, digits, '_', '.', '+', '-' passes")
            plan.definitions.append(f"-D{d.name}={value}" if value else f"-D{d.name}")
        if fileset.language:
            if fileset.language not in _STANDARDS:
                raise _refuse(path, instance, f"{where} gives the language "
                              f"{_shown(fileset.language)}, which twmr does not know (it knows "
                              f"{', '.join(_STANDARDS)})")
            plan.standards.append(f"-std={_STANDARDS[fileset.language]}")
    if not plan.sources:
        raise FmuError(instance, None, f"FMU '{path.name}' names no source file in {where}. "
                       f"Fix: get a build of the FMU for this platform.")
    return plan


def _compilers(path: Path, md: Any, plan: BuildPlan, instance: str) -> tuple[str, str]:
    """The C and C++ compilers ($CC, $CXX); FmuError when one the build needs is missing."""
    cc, cxx = os.environ.get("CC", "cc"), os.environ.get("CXX", "c++")
    needed = [cc] + ([cxx] if plan.cxx else [])
    missing = [tool for tool in needed if not shutil.which(tool)]
    if missing:
        raise FmuError(instance, None, f"FMU '{path.name}' ships C sources only (no binary for "
                       f"{binary_folders(md)[0]}), and compiling them needs "
                       f"{' and '.join(missing)}, which this machine lacks. Fix: install a C "
                       f"compiler (or set CC / CXX to one), or get a build of the FMU for this "
                       f"platform.")
    return cc, cxx


class _BuildFailed(Exception):
    """A compiler command that failed or ran out of time: (what happened, its output)."""


def _run(command: list[str], cwd: Path, deadline: float, timeout: float) -> None:
    """`command` in `cwd`, in a process group of its own, killed with it at the deadline."""
    proc = subprocess.Popen(command, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        output, _ = proc.communicate(timeout=max(deadline - time.monotonic(), 0.0))
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        try:
            output, _ = proc.communicate(timeout=5.0)
        except subprocess.TimeoutExpired:
            output = b""
        raise _BuildFailed(f"the build did not finish within {timeout:g} s and was stopped",
                           output) from None
    finally:
        if proc.poll() is None:  # interrupted (Ctrl-C): the compiler goes too
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    if proc.returncode:
        raise _BuildFailed(f"{Path(command[0]).name} exited with status {proc.returncode}",
                           output)


def _compile(plan: BuildPlan, sources: Path, binary: Path, compilers: tuple[str, str],
             timeout: float) -> None:
    """Each source to an object, then the shared library `binary`, in `sources`' parent."""
    import fmpy

    work = sources.parent
    headers = Path(fmpy.__file__).parent / "c-code"  # the FMI headers, when the FMU lacks them
    cc, cxx = compilers
    flags = ["-O2", "-fPIC", f"-I{sources}", *(f"-I{sources / i}" for i in plan.includes),
             f"-I{headers}", *plan.definitions]
    deadline = time.monotonic() + timeout
    objects = []
    for i, name in enumerate(plan.sources):
        cxx_source = name.endswith(_CXX)
        std = [s for s in plan.standards if s.startswith("-std=c++") == cxx_source]
        obj = work / f"object{i}.o"
        _run([cxx if cxx_source else cc, *std, *flags, "-c", str(sources / name), "-o",
              str(obj)], work, deadline, timeout)
        objects.append(str(obj))
    binary.parent.mkdir(parents=True)
    _run([cxx if plan.cxx else cc, "-shared", *objects, "-o", str(binary), "-lm"], work,
         deadline, timeout)


def build(path: Path, md: Any, out: Path, instance: str,
          timeout: float = DEFAULT_TIMEOUT) -> Path:
    """`out`: the FMU `path` with a binary for this platform compiled from its sources, written
    whole or not at all. FmuError naming what is at fault (a name, the compiler, the timeout
    [s]), with the compiler's last lines."""
    import fmpy

    plan = build_plan(path, md, instance)
    compilers = _compilers(path, md, plan, instance)
    library = f"binaries/{binary_folders(md)[0]}/{plan.identifier}{fmpy.sharedLibraryExtension}"
    with tempfile.TemporaryDirectory(prefix="twmr-fmu-build-") as scratch:
        work = Path(scratch)
        sources = work / "sources"
        with zipfile.ZipFile(path) as z:
            for info in z.infolist():
                if info.filename.startswith("sources/") and not info.is_dir():
                    target = sources / info.filename[len("sources/"):]  # names checked above
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(z.read(info))
        try:
            _compile(plan, sources, work / library, compilers, timeout)
        except _BuildFailed as failed:
            what, output = failed.args
            tail = output.decode("utf-8", "replace").strip().splitlines()[-6:]
            shown = f" Its last output: {' / '.join(tail)}." if tail else ""
            raise FmuError(instance, None, f"FMU '{path.name}' ships C sources only and "
                           f"building it failed: {what}.{shown} Fix: correct the FMU's sources "
                           f"or build it with its vendor's tool"
                           + (" (or give a longer compile_timeout:)" if "stopped" in what
                              else "") + ".") from None
        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(f".{out.name}.{os.getpid()}.part")
        try:
            with zipfile.ZipFile(path) as zin, \
                    zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zout:
                for info in zin.infolist():
                    if info.filename != library:
                        zout.writestr(info, zin.read(info))
                zout.write(work / library, library)
            os.replace(partial, out)
        finally:
            partial.unlink(missing_ok=True)
    return out


#: SHA-256 of a source-only FMU -> the FMU built from it in this process
_built: dict[str, Path] = {}


@functools.cache
def _scratch() -> Path:
    """This process's folder of FMUs built with `compile: true`, removed when it exits."""
    folder = Path(tempfile.mkdtemp(prefix="twmr-fmus-"))
    atexit.register(shutil.rmtree, folder, True)
    return folder


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def runnable(path: Path, md: Any, instance: str, compile: bool = False,
             timeout: float = DEFAULT_TIMEOUT) -> Path:
    """`path` itself when it has a binary for this platform; otherwise, with `compile`, the FMU
    built from its sources (once per process); FmuError when it has neither a binary nor
    sources, when a name in its sources is not plain, or when it was not asked to compile."""
    import fmpy

    if has_binary(path, md):
        missing = _missing_libraries(path, md)
        if missing:
            raise FmuError(instance, None, f"FMU '{path.name}' has a binaries folder for this "
                           f"platform but not the shared library its model description names "
                           f"({', '.join(missing)}). Fix: rebuild the FMU so the library is named "
                           f"after its modelIdentifier.")
        return path
    platform = binary_folders(md)[0]
    if not has_sources(md):
        platforms = ", ".join(fmpy.supported_platforms(str(path))) or "none"
        raise FmuError(instance, None, f"FMU '{path.name}' has no binary for this platform "
                       f"({platform}; it has: {platforms}) and no C sources to build one. Fix: "
                       f"get a build of the FMU for {platform}.")
    build_plan(path, md, instance)
    if not compile:
        raise FmuError(instance, None, f"FMU '{path.name}' ships C sources only (no binary for "
                       f"{platform}); building it runs the FMU's code on this machine, so twmr "
                       f"builds it only when asked. Fix: add `compile: true` under this "
                       f"component's parameters, or build a copy once with `twmr fmu build "
                       f"{path}` and use the FMU it writes.")
    key = _digest(path)
    if key not in _built:
        _built[key] = build(path, md, _scratch() / key / path.name, instance, timeout)
    return _built[key]
