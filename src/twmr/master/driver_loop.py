"""The compiled driver's loop (`twmr.master.driver`), compiled once for every scenario: it steps
a plan laid out as arrays and calls each block's kind through the C address of its adapter.
`run` and `finish` release the GIL while they step (they touch no Python object): the threads of
a run (a bus, the live view, the FMU guard's watchdog, which ends a run hung inside an FMU) go
on meanwhile.

The helpers are inlined into `run` and `finish` at numba's IR level (`inline="always"`): called,
they cost the paper scenario about a seventh of its step.

Imported only when a run is compiled (it imports numba)."""
from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

#: a sum of magnitudes below this bounds every sum of the same terms far from overflow
SAFE = 1e300
#: the adapters' signature: (t, h, S, X, P, len S, len X, len P, offset in S, X, P) -> 0, or
#: the code of a failed FMU call (`twmr.fmi.driver_kind`)
ADAPTER = types.int64(types.float64, types.float64, types.CPointer(types.float64),
                      types.CPointer(types.float64), types.CPointer(types.float64),
                      *(types.int64,) * 6)


def signatures() -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """numba's argument types of `run` and `finish` (the same for every scenario)."""
    f1, f2 = types.float64[::1], types.float64[:, ::1]
    i1, i2 = types.int64[::1], types.int64[:, ::1]
    i, f = types.int64, types.float64
    return ((i, i, f, f, f1, f1, f1, i2, f2, i2, i2, f1, i2, i1, f2, i),
            (i, f, f, f1, f1, f1, i2, f2, i2, i2, i1, f2))


@intrinsic
def _call(typingctx: Any, addr: Any, t: Any, h: Any, sp: Any, xp: Any, pp: Any, ns: Any,
          nx: Any, np_: Any, so: Any, xo: Any, po: Any) -> Any:
    """Call the adapter at C address `addr` with the vectors given by their data addresses."""
    i64, f64 = types.int64, types.float64
    sig = i64(i64, f64, f64, *(i64,) * 9)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        dbl, word = ir.DoubleType(), ir.IntType(64)
        ptr = dbl.as_pointer()
        fnty = ir.FunctionType(word, [dbl, dbl, ptr, ptr, ptr, *(word,) * 6])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        values = [args[1], args[2], *(builder.inttoptr(a, ptr) for a in args[3:6]), *args[6:]]
        return builder.call(fn, values)

    return sig, codegen


@intrinsic
def _vector(typingctx: Any, addr: Any) -> Any:
    """The float64 vector at C address `addr`, indexed without numba's wraparound of negative
    indices (every index of the plan is an offset >= 0)."""
    ptr = types.CPointer(types.float64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(ptr))

    return ptr(types.int64), codegen


@njit(cache=True, error_model="numpy", inline="always")
def _block(col: int, b: int, t: float, h: float, S: Any, X: Any, P: Any, blocks: Any) -> int:
    return _call(blocks[b, col], t, h, S.ctypes.data,  # type: ignore[call-arg]
                 X.ctypes.data, P.ctypes.data, S.size, X.size, P.size, blocks[b, 2],
                 blocks[b, 3], blocks[b, 4])


@njit(cache=True, error_model="numpy", inline="always")
def _point(n: int, t: float, final: bool, S: Any, X: Any, P: Any, ops: Any, gains: Any,
           blocks: Any) -> tuple[int, int]:
    """The point's program; (-1, 0), or (the block whose evaluation failed, its code)."""
    s: Any = _vector(S.ctypes.data)  # type: ignore[call-arg]
    for i in range(ops.shape[0]):
        m = ops[i, 3]
        if not final and m != 1 and n % m != 0:
            continue
        code = ops[i, 0]
        if code == 0:
            a = ops[i, 1]
            b = ops[i, 2]
            for e in range(ops[i, 4]):
                s[a + e] = s[b + e]
        elif code == 1:
            s[ops[i, 1]] = s[ops[i, 2]] * gains[i, 0] + gains[i, 1]
        else:
            r = _block(0, ops[i, 1], t, 0.0, S, X, P, blocks)
            if r != 0:
                return ops[i, 1], r
    return -1, 0


@njit(cache=True, error_model="numpy", inline="always")
def _magnitude(s: Any, chk: Any, i: int) -> float:
    """The sum of the magnitudes of the elements of the check's term `i`."""
    o = chk[i, 0]
    m = abs(s[o])
    for e in range(1, chk[i, 1]):
        m = m + abs(s[o + e])
    return m


@njit(cache=True, error_model="numpy", inline="always")
def _nonfinite(S: Any, chk: Any) -> bool:
    """The Python schedule's sum over the watched ports, chunk by chunk, is not finite. Its
    terms' magnitudes summed in four independent chains bound every partial sum: below `SAFE`
    none can overflow and no element is NaN or Inf, so the sum is finite; else the sum in the
    Python schedule's order says."""
    s: Any = _vector(S.ctypes.data)  # type: ignore[call-arg]
    n = chk.shape[0]
    a0 = a1 = a2 = a3 = 0.0
    i = 0
    while i + 4 <= n:
        a0 = a0 + _magnitude(s, chk, i)
        a1 = a1 + _magnitude(s, chk, i + 1)
        a2 = a2 + _magnitude(s, chk, i + 2)
        a3 = a3 + _magnitude(s, chk, i + 3)
        i += 4
    while i < n:
        a0 = a0 + _magnitude(s, chk, i)
        i += 1
    if (a0 + a1) + (a2 + a3) < SAFE:
        return False
    return _sum_nonfinite(s, chk)


@njit(cache=True, error_model="numpy")
def _sum_nonfinite(s: Any, chk: Any) -> bool:
    """The Python schedule's sum over the watched ports, chunk by chunk, is not finite."""
    v = 0.0
    cs = 0.0
    cur = -1
    for i in range(chk.shape[0]):
        o = chk[i, 0]
        term = s[o]
        for e in range(1, chk[i, 1]):
            term = term + s[o + e]
        if chk[i, 2] != cur:
            if cur >= 0:
                v = v + cs
            cs = term
            cur = chk[i, 2]
        else:
            cs = cs + term
    if cur >= 0:
        v = v + cs
    return v - v != 0.0


@njit(cache=True, error_model="numpy")
def _record(k: int, t: float, S: Any, rec: Any, buf: Any) -> None:
    s: Any = _vector(S.ctypes.data)  # type: ignore[call-arg]
    buf[k, 0] = t
    for j in range(rec.shape[0]):
        buf[k, 1 + j] = s[rec[j]]


@njit(cache=True, error_model="numpy", nogil=True)
def run(n0: int, n1: int, start: float, h: float, S: Any, X: Any, P: Any, ops: Any, gains: Any,
        blocks: Any, steps: Any, H: Any, chk: Any, rec: Any, buf: Any, dec: int
        ) -> tuple[int, int, int, int]:
    """Base steps n0..n1-1; (rows written to `buf`, the step of a NaN/Inf or of a failed
    FMU call or -1, the block of that call or -1, its code)."""
    k = 0
    bad = -1
    fb = -1
    fs = 0
    for n in range(n0, n1):
        t = start + n * h
        fb, fs = _point(n, t, False, S, X, P, ops, gains, blocks)
        if fb >= 0:
            bad = n
            break
        if chk.shape[0] and _nonfinite(S, chk):
            bad = n
            break
        if buf.shape[1] > 1 and n % dec == 0:
            _record(k, t, S, rec, buf)
            k += 1
        last = n == n1 - 1
        for i in range(steps.shape[0]):
            b = steps[i, 0]
            m = steps[i, 1]
            col = 5 if steps[i, 2] != 0 and not last else 1
            r = 0
            if m == 1:
                r = _block(col, b, t, H[b], S, X, P, blocks)
            elif n % m == m - 1:
                r = _block(col, b, t - (m - 1) * h, H[b], S, X, P, blocks)
            if r != 0:
                fb = b
                fs = r
                break
        if fb >= 0:
            bad = n
            break
    return k, bad, fb, fs


@njit(cache=True, error_model="numpy", nogil=True)
def finish(n: int, start: float, h: float, S: Any, X: Any, P: Any, ops: Any, gains: Any,
           blocks: Any, chk: Any, rec: Any, buf: Any) -> tuple[int, int, int, int]:
    """The final point at step n; (rows written, n when a NaN/Inf is seen or an FMU call
    fails else -1, the block of that call or -1, its code)."""
    t = start + n * h
    fb, fs = _point(n, t, True, S, X, P, ops, gains, blocks)
    if fb >= 0:
        return 0, n, fb, fs
    if chk.shape[0] and _nonfinite(S, chk):
        return 0, n, -1, 0
    if buf.shape[1] > 1:
        _record(0, t, S, rec, buf)
        return 1, -1, -1, 0
    return 0, -1, -1, 0
