"""FMU files unpacked once per process: the instances of one FMU file share its unpacked folder
(and so its shared library, loaded once), unless the FMU says it can be instantiated only once
per process — then each instance gets a copy of its own, a library of its own. A folder is
removed when its last instance gives it back; a changed file (size, time) is unpacked anew.
"""
from __future__ import annotations

import shutil
import tempfile
import threading
from pathlib import Path
from typing import Any

_lock = threading.Lock()
#: (file, its modification time [ns], its size) -> [unpacked folder, instances using it]
_held: dict[tuple[str, int, int], list[Any]] = {}


def take(path: Path, shared: bool) -> str:
    """The folder `path` is unpacked in: shared by every instance that takes it `shared`,
    else a copy of this instance's own. Raises what fmpy's `extract` raises."""
    from fmpy import extract

    if not shared:
        return str(extract(str(path), tempfile.mkdtemp(prefix="twmr-fmu-")))
    stat = path.stat()
    key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    with _lock:
        held = _held.get(key)
        if held is not None and Path(held[0]).is_dir():
            held[1] += 1
            return str(held[0])
        folder = str(extract(str(path), tempfile.mkdtemp(prefix="twmr-fmu-")))
        _held[key] = [folder, 1]
        return folder


def give_back(folder: str) -> None:
    """An instance is done with `folder`: removed when no other instance uses it."""
    with _lock:
        for key, held in list(_held.items()):
            if held[0] == folder:
                held[1] -= 1
                if held[1] > 0:
                    return
                del _held[key]
                break
    shutil.rmtree(folder, ignore_errors=True)
