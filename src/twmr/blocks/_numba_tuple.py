"""numba's side of `twmr.blocks.vectors` (imported only when compiled code calls it)."""
from numba.cpython.unsafe.tuple import tuple_setitem


def setitem(t: tuple, i: int, v: float) -> tuple:
    """`t` with element i replaced by v (numba's tuple intrinsic)."""
    return tuple_setitem(t, i, v)  # type: ignore[call-arg]
