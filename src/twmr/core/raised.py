"""Where an exception from a block came from, and Python's hint for it, for one-line messages:
`raised_at(exc)` names the file and line in the user's own code (else in twmr's), and `hint(exc)`
gives the "did you mean" Python 3.12 prints for a misspelt attribute or name."""
from __future__ import annotations

import difflib
import sys
import sysconfig
import traceback
from pathlib import Path


def _library_roots() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    return tuple(str(Path(paths[k]).resolve()) for k in ("stdlib", "platstdlib", "purelib",
                                                          "platlib") if k in paths)


def _twmr_roots() -> tuple[str, ...]:
    roots = []
    for name in ("twmr", "twmr.components", "twmr.hw"):
        module = sys.modules.get(name)
        for folder in getattr(module, "__path__", ()) or ():
            roots.append(str(Path(folder).resolve()))
    return tuple(roots)


def raised_at(exc: BaseException) -> tuple[str, bool]:
    """('file.py line 27: `return self.volage`', True) for the deepest frame of `exc`'s
    traceback in the user's code (outside twmr, the standard library and installed packages),
    else that of twmr's code with False; ('', False) when there is neither (the generated step
    loop, a C extension)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if not f.filename.startswith("<")]
    libraries, ours = _library_roots(), _twmr_roots()

    def place(frame: traceback.FrameSummary) -> str:
        code = f": `{frame.line.strip()}`" if frame.line else ""
        return f"{frame.filename} line {frame.lineno}{code}"

    resolved = [(f, str(Path(f.filename).resolve())) for f in frames]
    for frame, path in reversed(resolved):
        if not path.startswith(ours) and not path.startswith(libraries):
            return place(frame), True
    for frame, path in reversed(resolved):
        if path.startswith(ours):
            return place(frame), False
    return "", False


def described(call: str, exc: BaseException, fix: str) -> str:
    """'<call> raised <Type>: <text>. Did you mean ...? (at <file> line <n>: `<code>`). Fix: ...'
    with `fix` when the fault is not in the user's own code there."""
    where, user = raised_at(exc)
    text = f"{call} raised {type(exc).__name__}: {exc}.{hint(exc)}"
    if where:
        text += f" (at {where})"
    if user:
        return text + ". Fix: correct the code there (--debug shows the whole traceback)."
    return f"{text}. Fix: {fix}"


def hint(exc: BaseException) -> str:
    """" Did you mean 'voltage'?" for an AttributeError or NameError with a close name, else
    ''."""
    name = getattr(exc, "name", None)
    if not isinstance(name, str):
        return ""
    if isinstance(exc, AttributeError):
        candidates = dir(getattr(exc, "obj", None)) if hasattr(exc, "obj") else []
    elif isinstance(exc, NameError):
        tb = exc.__traceback__
        while tb is not None and tb.tb_next is not None:
            tb = tb.tb_next
        frame = tb.tb_frame if tb is not None else None
        candidates = [*frame.f_locals, *frame.f_globals, *dir(__builtins__)] \
            if frame is not None else []
    else:
        return ""
    close = difflib.get_close_matches(name, [c for c in candidates if c != name], n=1,
                                      cutoff=0.75)
    return f" Did you mean '{close[0]}'?" if close else ""
