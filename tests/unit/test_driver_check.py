"""The compiled driver's NaN/Inf check (`twmr.master.driver_loop._nonfinite`) says what the Python
schedule's sum over the watched ports says — each port's elements summed, the ports of a chunk
summed, the chunks summed, in that order — also when that sum overflows with every element finite
and when it would not in another order."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from twmr.master.driver_loop import _nonfinite

#: the watched ports: (elements, chunk) each; a chunk's ports follow one another
Ports = list[tuple[list[float], int]]

values = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                   st.floats(min_value=-1.7e308, max_value=1.7e308),
                   st.sampled_from([1e308, -1e308, 9e307, 1e300, 0.0]))
ports = st.lists(st.tuples(st.lists(values, min_size=1, max_size=5), st.booleans()),
                 min_size=1, max_size=12)


def python_sum(watched: Ports) -> float:
    """The sum in the Python schedule's order."""
    chunks: list[list[list[float]]] = []
    last = None
    for elements, chunk in watched:
        if chunk != last:
            chunks.append([])
            last = chunk
        chunks[-1].append(elements)
    v = 0.0
    for chunk_ports in chunks:
        cs = 0.0
        for j, elements in enumerate(chunk_ports):
            term = elements[0]
            for x in elements[1:]:
                term = term + x
            cs = term if j == 0 else cs + term
        v = v + cs
    return v


def driver_check(watched: Ports) -> bool:
    """`_nonfinite` over the ports laid out in a vector after an unwatched element."""
    S, chk = [7.0], []
    for elements, chunk in watched:
        chk.append((len(S), len(elements), chunk))
        S.extend(elements)
    return bool(_nonfinite(np.array(S), np.array(chk, dtype=np.int64).reshape(-1, 3)))


def chunked(drawn: list[tuple[list[float], bool]]) -> Ports:
    """The drawn ports with a new chunk wherever the flag is set."""
    out, chunk = [], 0
    for elements, new in drawn:
        chunk += new
        out.append((elements, chunk))
    return out


@settings(max_examples=400, deadline=None, derandomize=True, database=None)
@given(ports)
def test_the_check_says_what_the_python_sum_says(drawn: list[tuple[list[float], bool]]) -> None:
    watched = chunked(drawn)
    assert driver_check(watched) == (not math.isfinite(python_sum(watched)))


def test_an_overflow_of_finite_elements_is_seen_in_the_python_order() -> None:
    assert driver_check([([1e308, 1e308], 0), ([-1e308], 0)])  # (a + b) + c overflows
    assert not driver_check([([1e308], 0), ([1e308, -1e308], 0)])  # a + (b + c) does not
    assert not driver_check([([1e299] * 8, 0), ([-1e299], 1)])
    assert driver_check([([0.0, math.nan], 0)])
