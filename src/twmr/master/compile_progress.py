"""Progress of a compile that takes long: a line in the run's log after `FIRST` seconds of it,
and again every `EVERY` seconds until it ends (numba compiles a new kind of block, or a
scenario's own loop, in seconds; reading it back from the cache later takes a fraction of one).
The lines come from a thread of their own: numba's LLVM passes run outside the GIL."""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

log = logging.getLogger("twmr.run")

#: seconds of compiling before the first line, then between lines
FIRST, EVERY = 2.0, 5.0


@contextmanager
def compile_progress(what: str, likely: bool = True) -> Iterator[None]:
    """Log how long compiling `what` has taken while the block runs longer than `FIRST` s;
    nothing (no thread started) unless a compile is `likely`."""
    if not likely:
        yield
        return
    done = threading.Event()
    t0 = time.perf_counter()

    def report() -> None:
        wait = FIRST
        while not done.wait(wait):
            took = time.perf_counter() - t0
            log.info("compiling %s (numba; what its cache holds is read back): %.0f s so far; "
                     "later runs read it from the cache in a fraction of a second", what, took)
            wait = EVERY

    thread = threading.Thread(target=report, name="twmr-compile-progress", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
