"""Whether starting local worker processes would run the user's script again: Dask starts them
with `multiprocessing`'s spawn, which imports the script's `__main__` module anew in each; a call
that starts them at the script's top level, not under `if __name__ == "__main__":`, then starts
them again in every worker, and Dask ends in a long traceback ("Nanny failed to start").
`unguarded_call()` finds that call before any process starts."""
from __future__ import annotations

import ast
import sys
from pathlib import Path
from types import FrameType


def _guards(tree: ast.Module) -> list[tuple[int, int]]:
    """Line ranges of the bodies of `if __name__ == "__main__":` at a module's top level."""
    spans = []
    for node in tree.body:
        if not isinstance(node, ast.If):
            continue
        test = node.test
        if isinstance(test, ast.Compare) and len(test.ops) == 1 and \
                isinstance(test.ops[0], ast.Eq):
            sides = [test.left, *test.comparators]
            names = {s.id for s in sides if isinstance(s, ast.Name)}
            texts = {s.value for s in sides if isinstance(s, ast.Constant)}
            if names == {"__name__"} and texts == {"__main__"} and node.body:
                spans.append((node.body[0].lineno, node.body[-1].end_lineno or
                              node.body[-1].lineno))
    return spans


def unguarded_call(frame: FrameType | None = None) -> tuple[str, int] | None:
    """(script, line) of the top-level statement of the running script (`__main__` from a
    file) that led here when that statement is outside `if __name__ == "__main__":`; None when
    it is inside one, when the script is not a file (a notebook, `python -c`, the console, the
    `twmr` command), or when it cannot be read or was changed since it started (its text no
    longer compiles to the code that runs: lines read now would name other statements)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not str(path).endswith(".py"):
        return None
    f: FrameType | None = frame if frame is not None else sys._getframe(1)
    top = None
    while f is not None:
        if f.f_code.co_name == "<module>" and f.f_globals.get("__name__") == "__main__":
            top = f
        f = f.f_back
    if top is None:
        return None
    try:
        text = Path(path).read_text(encoding="utf-8")
        tree = ast.parse(text)
        now = compile(tree, str(path), "exec", dont_inherit=True)
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return None
    running = top.f_code
    if (now.co_code, now.co_linetable) != (running.co_code, running.co_linetable):
        return None
    line = top.f_lineno
    if any(lo <= line <= hi for lo, hi in _guards(tree)):
        return None
    return str(path), line
