"""`ResultStore.data` hands out the rows kept in memory without a copy when its blocks are
consecutive rows of one array (a compiled run's chunks), and joins them by a copy otherwise."""
from __future__ import annotations

import numpy as np

from twmr.observers.store import ResultStore


def kept(blocks: list[np.ndarray]) -> ResultStore:
    store = ResultStore()
    for b in blocks:
        store.rows(b, 0)
    return store


def test_consecutive_rows_of_one_buffer_are_handed_out_as_one_view() -> None:
    whole = np.empty((10, 3))
    whole[:] = np.arange(30.0).reshape(10, 3)
    data = kept([whole[1:3], whole[3:3], whole[3:7], whole[7:8]]).data()
    assert np.shares_memory(data, whole) and np.array_equal(data, whole[1:8])


def test_other_blocks_are_copied_in_their_order() -> None:
    whole = np.empty((10, 3))
    whole[:] = np.arange(30.0).reshape(10, 3)
    other = whole.copy() + 100.0
    for blocks in ([whole[1:3], whole[4:6]],  # a gap
                   [whole[4:6], whole[1:3]],  # out of order
                   [whole[1:3, :2], whole[3:5, :2]],  # columns of it
                   [whole[1:3], other[3:5]],  # another buffer
                   [whole[1:3].copy(), whole[3:5]]):
        data = kept(blocks).data()
        assert not np.shares_memory(data, whole)
        assert np.array_equal(data, np.concatenate(blocks))
