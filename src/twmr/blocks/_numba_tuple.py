"""numba's side of `twmr.blocks.vectors` (imported only when compiled code calls it)."""
from typing import Any

from numba.core import types
from numba.cpython.unsafe.tuple import tuple_setitem
from numba.extending import overload


def _replace(t: tuple, i: int, v: float) -> tuple:
    raise NotImplementedError("compiled code only")


@overload(_replace)
def _replace_typed(t: Any, i: Any, v: Any) -> Any:
    """numba's tuple intrinsic for a tuple; for anything else no implementation (a typing error,
    which numba accepts in a branch pruned by `isinstance`)."""
    if not isinstance(t, types.UniTuple):
        return None

    def replace(t: Any, i: Any, v: Any) -> Any:  # the typing function's signature
        return tuple_setitem(t, i, v)  # type: ignore[call-arg]
    return replace


def setitem(t: tuple, i: int, v: float) -> tuple:
    """`t` with element i replaced by v."""
    return _replace(t, i, v)
