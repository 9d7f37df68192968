"""`Workers`: a local Dask cluster kept open across the sweeps, tunes and fits of one Python
process (`with twmr.Workers(2): twmr.sweep(...); twmr.tune(...)`), so they do not each start
and stop worker processes: its workers keep the engine imported, the compiled kinds loaded and
the scenarios built (`twmr.sweeps.run`) from one call to the next.

Inside the `with` block a call that would start a local cluster (`workers` not 1, no
`scheduler`) takes these workers instead when it asks for as many or leaves the number to the
default; it connects a client of its own and closes only that. The workers keep the code they
imported: a block of your own edited between two calls is seen by the next `with` block, not
by this one. The cluster listens on 127.0.0.1, as every local cluster of a sweep.
"""
from __future__ import annotations

import os
from typing import Any

from twmr.sweeps.engine import OPEN_POOLS, close_client, dask_client


class Workers:
    """A local cluster of `n` worker processes (default: one per core) for the calls inside
    the `with` block; `dashboard`: Dask's dashboard on 127.0.0.1."""

    def __init__(self, n: int | None = None, *, dashboard: bool = False) -> None:
        self.n = n
        self.dashboard = dashboard
        self.client: Any = None
        self.cluster: Any = None

    def __enter__(self) -> Workers:
        self.client, self.cluster = dask_client(self.n, None, self.dashboard, pooled=False)
        self.n = len(self.cluster.workers)
        OPEN_POOLS.append(self)
        return self

    def __exit__(self, *exc: object) -> None:
        OPEN_POOLS.remove(self)
        close_client(self.client, self.cluster, [])
        self.client = self.cluster = None

    @property
    def pids(self) -> list[int]:
        """The worker processes' ids (for a check that calls shared them)."""
        info = self.client.run(os.getpid)
        return sorted(info.values())
