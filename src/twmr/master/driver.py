"""The compiled step loop without a compile per scenario: each kind of block compiled once, one
driver loop for every scenario.

A scenario's `Plan` is laid out as arrays (`Layout`): one float64 vector S of every port element
(each block's outputs, then its inputs, declared order; under Jacobi a snapshot area after them),
one of every block's private state X and one of its parameters P (scalars as themselves, ints and
bools as floats, arrays as their shape then their elements), a table of blocks (the C addresses of
its kind's adapters, offsets into S, X and P), a program of the point (runs of element copies,
scaled copies with their unit gain and offset, evaluations, each with its step multiple), the
steps (a block that `plan.advancing` names and whose kernel has `advance` advances by it,
its outputs at the step's end left to the next point's evaluation, except at a chunk's last
step, after which the components get the values the Python schedule gives them), the terms of
the NaN/Inf check and the recorded elements. The driver
(`twmr.master.driver_loop`, compiled once) interprets them and calls each block through its
kind's adapter, which rebuilds the kernel's own arguments (tuples, NamedTuples, arrays) from its
slices, calls the unchanged kernel functions and writes their results back.

A kind is the kernel functions with the shapes of x, y, u and p (`KindSpec`): a thousand
gain blocks are one kind. Its adapters are a module of their own (`kind_<hash>.py` in the cache
folder, numba's machine code beside it), compiled the first time the kind is met and loaded
after that; the driver's argument types never change. So a rewired scenario, one with more
blocks, or another mix of known kinds runs compiled without compiling anything, and a new kind
costs the compile of that kind alone. Every element is computed by the same expression, in the
same order, as the Python schedule, so the rows are bit-identical.
"""
from __future__ import annotations

import dataclasses
import functools
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twmr.core.kernel import Kernel
from twmr.master.plan import Evaluate, Plan, Write, advancing, input_elements
from twmr.scenario.system import Connection, System

#: the shape of a kernel value: 'f' float, 'i' int, 'b' bool, ('a', ndim) a float64 array,
#: ('t', NamedTuple class or None, (shapes...)) a tuple
Shape = Any
#: opcodes of the point's program
COPY, SCALE, EVAL = 0, 1, 2


class Unsupported(Exception):
    """A value the driver cannot hold in its float vectors (its text says which)."""


#: the shapes of the scalar types kernel values hold, by exact type (a run of a built system
#: takes the shapes of its kernels' values anew: this spares the tests below)
_SCALARS: dict[type, str] = {float: "f", np.float64: "f", int: "i", np.int64: "i", bool: "b",
                             np.bool_: "b"}


def shape_of(value: Any) -> Shape:
    """The shape of a kernel state or parameter value; `Unsupported` for anything else."""
    scalar = _SCALARS.get(type(value))
    if scalar is not None:
        return scalar
    if isinstance(value, tuple):
        cls = type(value) if hasattr(value, "_fields") else None
        if cls is not None and not _importable(cls):
            raise Unsupported(f"its NamedTuple {cls.__qualname__} is not importable")
        return ("t", cls, tuple([shape_of(v) for v in value]))
    if isinstance(value, (bool, np.bool_)):
        return "b"
    if isinstance(value, (int, np.integer)):
        return "i"
    if isinstance(value, (float, np.floating)) and np.dtype(type(value)) == np.float64:
        return "f"
    if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim >= 1:
        return ("a", value.ndim)
    raise Unsupported(f"a value of type {type(value).__name__}")


def flatten(value: Any, shape: Shape, out: list[float]) -> None:
    """Append `value`'s elements (arrays: shape, then elements) to `out`."""
    if shape in ("f", "i", "b"):
        out.append(float(value))
    elif shape[0] == "a":
        out.extend(float(d) for d in value.shape)
        out.extend(np.ravel(value).tolist())
    else:
        for v, s in zip(value, shape[2], strict=True):
            if s in ("f", "i", "b"):  # (inline: a table of scalars costs no call per element)
                out.append(float(v))
            else:
                flatten(v, s, out)


def rebuild(vec: np.ndarray | list[float], o: int, shape: Shape) -> tuple[Any, int]:
    """(the Python value of `shape` stored in `vec` from `o`, the offset after it); `vec` a
    vector or its elements as a list (`tolist()`: read without making numpy scalars)."""
    if shape == "f":
        return float(vec[o]), o + 1
    if shape == "i":
        return int(vec[o]), o + 1
    if shape == "b":
        return bool(vec[o]), o + 1
    if shape[0] == "a":
        dims = tuple(int(d) for d in vec[o:o + shape[1]])
        o += shape[1]
        n = int(np.prod(dims))
        return np.array(vec[o:o + n], dtype=np.float64).reshape(dims), o + n
    items = []
    for s in shape[2]:
        if s == "f":  # (inline: a table of floats costs no call per element)
            items.append(float(vec[o]))
            o += 1
        else:
            v, o = rebuild(vec, o, s)
            items.append(v)
    return (shape[1](*items) if shape[1] is not None else tuple(items)), o


@dataclass(frozen=True)
class KindSpec:
    """One kind of block as the driver sees it: its kernel functions and value shapes (sizes of
    the output and input ports: None a scalar, n a tuple of n); for an FMU, the shape of its
    calls (`twmr.fmi.driver_kind.FmuShape`) instead of kernel functions."""

    evaluate: Any
    step: Any
    advance: Any
    state: Shape
    params: Shape
    outputs: tuple[int | None, ...]
    inputs: tuple[int | None, ...]
    fmu: Any = None

    @functools.cached_property
    def key(self) -> str:
        """The adapters' source: equal keys, one adapter (rendered once per process: `kind_of`
        hands out one object per kind)."""
        if self.fmu is not None:
            from twmr.fmi.driver_kind import adapters

            return adapters(self.fmu)
        return _adapters(self)


#: the kinds this process has met, each the one object `kind_of` hands out for kinds equal to it
_KINDS: dict[KindSpec, KindSpec] = {}


def kind_of(comp: Any, kern: Kernel) -> KindSpec:
    """The `KindSpec` of component `comp` with kernel `kern` (`Unsupported`: cannot be held)."""
    for fn in (kern.evaluate, kern.step, kern.advance):
        if fn is not None and not _importable(fn):
            raise Unsupported(f"its kernel function {getattr(fn, '__qualname__', fn)!r} is "
                              f"not importable by name")
    outputs: list[int | None] = []  # `comp.outputs` and `comp.inputs`, in one pass
    inputs: list[int | None] = []
    for v in comp.variables.values():
        if v.kind in ("output", "state"):
            outputs.append(None if v.size is None else v.width)
        elif v.kind == "input":
            inputs.append(None if v.size is None else v.width)
    if kern.fmu is not None:
        from twmr.fmi.driver_kind import NotInDriver, fmu_params, fmu_shape

        try:
            kind = KindSpec(None, None, None, shape_of(()), shape_of(fmu_params(kern.params)),
                            tuple(outputs), tuple(inputs), fmu_shape(comp, kern.fmu))
        except NotInDriver as exc:
            raise Unsupported(str(exc)) from None
    else:
        kind = KindSpec(kern.evaluate, kern.step, kern.advance, shape_of(kern.state),
                        shape_of(kern.params), tuple(outputs), tuple(inputs))
    return _KINDS.setdefault(kind, kind)


def _importable(obj: Any) -> bool:
    mod = sys.modules.get(getattr(obj, "__module__", ""), None)
    name = getattr(obj, "__qualname__", "<none>")
    return mod is not None and getattr(mod, name, None) is obj and "<" not in name


def _width(size: int | None) -> int:
    return 1 if size is None else size


# -- the generated source ----------------------------------------------------------------------
class _Src:
    def __init__(self) -> None:
        self.lines: list[str] = []
        self.n = 0

    def add(self, indent: int, text: str) -> None:
        self.lines.append("    " * indent + text)

    def var(self) -> str:
        self.n += 1
        return f"v{self.n}"


def _read(src: _Src, ind: int, vec: str, shape: Shape, imports: dict[str, str]) -> str:
    """Lines that read `shape` from `vec` at the running offset `o`; the expression of it."""
    if shape in ("f", "i", "b"):
        v = src.var()
        conv = {"f": "{}", "i": "int({})", "b": "{} != 0.0"}[shape]
        src.add(ind, f"{v} = {conv.format(f'{vec}p[o]')}")
        src.add(ind, "o += 1")
        return v
    if shape[0] == "a":
        v, nd = src.var(), shape[1]
        dims = [f"int({vec}p[o + {d}])" for d in range(nd)]
        src.add(ind, f"{v}n = {' * '.join(dims)}")
        if nd == 1:
            src.add(ind, f"{v} = {vec}[o + 1:o + 1 + {v}n]")
        else:
            src.add(ind, f"{v} = {vec}[o + {nd}:o + {nd} + {v}n].reshape(({', '.join(dims)},))")
        src.add(ind, f"o += {nd} + {v}n")
        return v
    items = [_read(src, ind, vec, s, imports) for s in shape[2]]
    tup = "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"
    if shape[1] is None:
        return tup
    alias = f"nt_{shape[1].__module__.replace('.', '_')}_{shape[1].__qualname__}"
    imports[alias] = f"from {shape[1].__module__} import {shape[1].__qualname__} as {alias}"
    return f"{alias}{tup if items else '()'}"


def _write(src: _Src, ind: int, expr: str, shape: Shape) -> None:
    """Lines that store `expr` of `shape` into X at the running offset `o`."""
    if shape in ("f", "i", "b"):
        src.add(ind, f"Xp[o] = {expr}")
        src.add(ind, "o += 1")
    elif shape[0] == "a":
        v = src.var()
        src.add(ind, f"{v} = np.ascontiguousarray({expr}).ravel()")
        src.add(ind, f"X[o + {shape[1]}:o + {shape[1]} + {v}.size] = {v}")
        src.add(ind, f"o += {shape[1]} + {v}.size")
    else:
        if not shape[2]:
            return
        t = src.var()
        src.add(ind, f"{t} = {expr}")
        for j, s in enumerate(shape[2]):
            _write(src, ind, f"{t}[{j}]", s)


def _has_array(shape: Shape) -> bool:
    """Whether a value of `shape` holds an array (read and written as a slice of its vector;
    scalars are read and written through the vector's pointer)."""
    return shape not in ("f", "i", "b") and (shape[0] == "a" or any(map(_has_array, shape[2])))


def _ports(sizes: tuple[int | None, ...], start: int) -> tuple[str, int]:
    """(tuple expression of the ports of `sizes` read from S at so + start, the offset after)."""
    items, o = [], start
    for size in sizes:
        if size is None:
            items.append(f"Sp[so + {o}]")
        else:
            items.append("(" + ", ".join(f"Sp[so + {o + e}]" for e in range(size)) +
                         ("," if size == 1 else "") + ")")
        o += _width(size)
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")", o


def _adapters(kind: KindSpec, imports: dict[str, str] | None = None) -> str:
    """Source of `ev` and `st` (those the kind has), of the signature `driver_loop.ADAPTER`:
    rebuild x, y, u, p from the vectors, call the kernel, store x and y back (scalars through
    the pointers: no index wraparound, no array built)."""
    imports = {} if imports is None else imports
    src = _Src()
    for fn, name in ((kind.evaluate, "ev"), (kind.step, "st"), (kind.advance, "ad")):
        if fn is None:
            continue
        alias = f"k_{fn.__module__.replace('.', '_')}_{fn.__qualname__}"
        imports[alias] = f"from {fn.__module__} import {fn.__qualname__} as {alias}"
        src.add(0, "@njit(cache=True, error_model='numpy')")
        src.add(0, f"def {name}(t, h, Sp, Xp, Pp, nS, nX, nP, so, xo, po):")
        for vec, shape in (("X", kind.state), ("P", kind.params)):
            if _has_array(shape):
                src.add(1, f"{vec} = carray({vec}p, (n{vec},))")
        src.add(1, "o = po")
        p = _read(src, 1, "P", kind.params, imports)
        src.add(1, "o = xo")
        x = _read(src, 1, "X", kind.state, imports)
        y, end = _ports(kind.outputs, 0)
        u, _ = _ports(kind.inputs, end)
        src.add(1, f"r = {alias}({'t' if name == 'ev' else 't, h'}, {x}, {y}, {u}, {p})")
        src.add(1, "o = xo")
        _write(src, 1, "r[0]", kind.state)
        src.add(1, "ry = r[1]")
        o = 0
        for j, size in enumerate(kind.outputs):
            if size is None:
                src.add(1, f"Sp[so + {o}] = ry[{j}]")
            else:
                for e in range(size):
                    src.add(1, f"Sp[so + {o + e}] = ry[{j}][{e}]")
            o += _width(size)
        src.add(1, "return 0")
        src.add(0, "")
        src.add(0, "")
    return "\n".join(src.lines)


def generate(kind: KindSpec) -> tuple[str, dict[str, Any]]:
    """(source of the module of `kind`'s adapters, {alias: kernel function}; for an FMU kind
    a function of the package whose sources its machine code depends on)."""
    if kind.fmu is not None:
        from twmr.fmi import driver_kind

        return kind.key, {"adapters": driver_kind.adapters}
    imports: dict[str, str] = {}
    body = _adapters(kind, imports)
    names = {f"k_{fn.__module__.replace('.', '_')}_{fn.__qualname__}": fn
             for fn in (kind.evaluate, kind.step, kind.advance) if fn is not None}
    head = ["# generated by twmr.master.driver: the adapters of one kind of block",
            "import numpy as np", "from numba import carray, njit", *sorted(imports.values()),
            "", ""]
    return "\n".join(head) + body, names


# -- the arrays of one scenario ------------------------------------------------------------------
@dataclass
class Layout:
    """The flat arrays of one system's plan (see the module docstring)."""

    S: np.ndarray
    X: np.ndarray
    P: np.ndarray
    ops: np.ndarray
    gains: np.ndarray
    blocks: np.ndarray
    steps: np.ndarray
    H: np.ndarray
    chk: np.ndarray
    rec: np.ndarray
    #: per block (in plan order): its ports (name, offset in S, width: None a scalar), and its
    #: offset in X and its state's shape
    ports: list[list[tuple[str, int, int | None]]]
    state: list[tuple[int, Shape]]


#: the attribute of a `System` holding its last layout: (plan, key, layout)
_HELD_LAYOUT = "_held_layout"


def held_layout(system: System, plan: Plan, kernels: dict[str, Kernel],
                addresses: dict[str, tuple[int, int, int]], kinds: dict[str, KindSpec]
                ) -> Layout:
    """`layout`, kept on `system`: for the same plan object (`plan.held_build`), kinds,
    adapters and step, the layout made before with the values of now (ports, states,
    parameters) in new vectors, while each block's state and parameters fill what they filled
    (an array of another length lays the plan out anew)."""
    key = (tuple(kinds[n] for n in plan.order),
           tuple(addresses[kinds[n].key] for n in plan.order), system.experiment.step)
    held = system.__dict__.get(_HELD_LAYOUT)
    if held is not None and held[0] is plan and held[1] == key:
        lay = _refilled(system, plan, kernels, kinds, held[2])
        if lay is not None:
            system.__dict__[_HELD_LAYOUT] = (plan, key, lay)
            return lay
    lay = layout(system, plan, kernels, addresses, kinds)
    system.__dict__[_HELD_LAYOUT] = (plan, key, lay)
    return lay


def _refilled(system: System, plan: Plan, kernels: dict[str, Kernel],
              kinds: dict[str, KindSpec], lay: Layout) -> Layout | None:
    """`lay` with new vectors S, X, P of the values of now; None when a block's state or
    parameters no longer fill the places they had."""
    S, X, P, places = _vectors(system, plan, kernels, kinds, lay.ports)
    if places != list(map(tuple, lay.blocks[:, 3:5].tolist())) or \
            X.size != lay.X.size or P.size != lay.P.size:
        return None
    return dataclasses.replace(lay, S=S, X=X, P=P)


def _vectors(system: System, plan: Plan, kernels: dict[str, Kernel], kinds: dict[str, KindSpec],
             ports: list[list[tuple[str, int, int | None]]]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """(S, X, P, each block's offsets in X and P): the values of now of the ports `ports`
    (per block in plan order, as `Layout.ports`) and the snapshot area after them, of the
    kernels' states and of their parameters."""
    comps = system.components
    S: list[float] = []
    X: list[float] = []
    P: list[float] = []
    places: list[tuple[int, int]] = []
    for name, block in zip(plan.order, ports, strict=True):
        d, kern, kind = comps[name].__dict__, kernels[name], kinds[name]
        for port, _, size in block:
            if size is None:
                S.append(float(d[port]))
            else:
                S.extend([float(v) for v in d[port]])
        places.append((len(X), len(P)))
        flatten(kern.state, kind.state, X)
        if kind.fmu is not None:
            from twmr.fmi.driver_kind import fmu_params

            flatten(fmu_params(kern.params), kind.params, P)
        else:
            flatten(kern.params, kind.params, P)
    slot = {(name, port): o for name, block in zip(plan.order, ports, strict=True)
            for port, o, _ in block} if plan.snapshot else {}
    for src, port in plan.snapshot:
        S.extend(S[slot[(src, port)]:slot[(src, port)] + comps[src].variables[port].width])
    return (np.array(S, dtype=np.float64), np.array(X, dtype=np.float64),
            np.array(P, dtype=np.float64), places)


def layout(system: System, plan: Plan, kernels: dict[str, Kernel],
           addresses: dict[str, tuple[int, int, int]], kinds: dict[str, KindSpec]) -> Layout:
    """The arrays of `plan` over `kernels`; `kinds[name]` is the kind of component `name`,
    `addresses[key]` the C addresses of kind `key`'s evaluate, step and advance adapters (0:
    none)."""
    comps = system.components
    exp = system.experiment
    slot: dict[tuple[str, str], int] = {}
    ports: list[list[tuple[str, int, int | None]]] = []
    starts: list[int] = []
    width = 0
    for name in plan.order:
        comp = comps[name]
        starts.append(width)
        ports.append([])
        held = {**comp.outputs, **comp.inputs}
        if kinds[name].fmu is not None:
            from twmr.fmi.driver_kind import real_ports

            held = real_ports(comp)
        for port, var in held.items():
            slot[(name, port)] = width
            ports[-1].append((port, width, None if var.size is None else var.width))
            width += var.width
    S, X, P, places = _vectors(system, plan, kernels, kinds, ports)
    blocks: list[tuple[int, ...]] = []
    state: list[tuple[int, Shape]] = []
    for name, so, (xo, po) in zip(plan.order, starts, places, strict=True):
        ev, st, ad = addresses[kinds[name].key]
        blocks.append((ev, st, so, xo, po, ad))
        state.append((xo, kinds[name].state))
    snap: dict[tuple[str, str], int] = {}
    for src, port in plan.snapshot:
        snap[(src, port)] = width
        width += comps[src].variables[port].width
    incoming: dict[tuple[str, str], list[Connection]] = {}
    for conn in system.connections:
        incoming.setdefault((conn.dst, conn.dst_port), []).append(conn)
    ops: list[list[int]] = []
    gains: list[tuple[float, float]] = []

    def op(code: int, a: int, b: int, m: int, gain: tuple[float, float] = (1.0, 0.0)) -> None:
        """Append an op; a copy that continues the previous one joins it (one run of
        elements)."""
        last = ops[-1] if ops else None
        if code == COPY and last is not None and last[0] == COPY and last[3] == m and \
                last[1] + last[4] == a and last[2] + last[4] == b:
            last[4] += 1
            return
        ops.append([code, a, b, m, 1])
        gains.append(gain)

    for (src, port), at in snap.items():
        for e in range(comps[src].variables[port].width):
            op(COPY, at + e, slot[(src, port)] + e, 1)
    index = {name: b for b, name in enumerate(plan.order)}
    for action in plan.point:
        if isinstance(action, Write):
            base = snap if snap else slot
            for d, src, port, s, gain, offset in input_elements(
                    system, incoming[(action.name, action.port)]):
                dst = slot[(action.name, action.port)] + d
                frm = base[(src, port)] + (s or 0)
                if gain is None:
                    op(COPY, dst, frm, action.multiple)
                else:
                    op(SCALE, dst, frm, action.multiple, (gain, offset))
        else:
            assert isinstance(action, Evaluate)
            op(EVAL, index[action.name], 0, action.multiple)
    lean = advancing(system, plan)
    steps = [(index[s.name], s.multiple,
              int(s.name in lean and kernels[s.name].advance is not None))
             for s in plan.steps
             if kernels[s.name].step is not None or kernels[s.name].fmu is not None]
    chk = [(slot[(s.name, s.port)], _width(s.size), c)
           for c, chunk in enumerate(plan.check) for s in chunk]
    rec = [slot[(s.name, s.port)] + e for s in plan.record for e in range(_width(s.size))]
    H = [system.multiple(n) * exp.step for n in plan.order]

    def ints(rows: list[Any], cols: int) -> np.ndarray:
        return np.array(rows, dtype=np.int64).reshape(len(rows), cols)

    return Layout(S, X, P, ints(ops, 5),
                  np.array(gains, dtype=np.float64).reshape(len(gains), 2), ints(blocks, 6),
                  ints(steps, 3), np.array(H, dtype=np.float64), ints(chk, 3),
                  np.array(rec, dtype=np.int64), ports, state)


# -- the compiled kinds ------------------------------------------------------------------------
#: the C addresses of the adapters of the kinds this process has compiled (or loaded), by key
_LOADED: dict[str, tuple[int, int, int]] = {}
#: the adapters compiled without the cache folder (their machine code lives as long as they do)
_HELD: list[dict[str, Any]] = []


def _address(fn: Any) -> int:
    """The C address of adapter `fn` compiled for `driver_loop.ADAPTER`."""
    from twmr.master.driver_loop import ADAPTER

    fn.compile(ADAPTER)
    cres = fn.overloads[ADAPTER.args]
    return int(cres.library.get_pointer_to_function(cres.fndesc.llvm_cfunc_wrapper_name))


def load(kinds: Sequence[KindSpec], folder: Callable[[], Any]
         ) -> tuple[dict[str, tuple[int, int, int]], int]:
    """({key: (evaluate, step, advance) adapter addresses} of `kinds`, how many kinds numba
    compiled or loaded now): those this process holds, the others generated, loaded through
    the verified cache in the folder `folder()` gives (asked only then;
    `twmr.master.schedule_cache`; exec'd without a cache when it cannot be written) and
    compiled."""
    from twmr.master import driver_loop, schedule_cache

    fresh = 0
    for kind in {k.key: k for k in kinds}.values():
        if kind.key in _LOADED:
            continue
        source, names = generate(kind)
        try:
            module = schedule_cache.load_module(source, names, folder(), "kind")
            env: dict[str, Any] = vars(module)
        except OSError:
            env = dict(names)
            exec(compile(source.replace("cache=True", "cache=False"),  # noqa: S102 - generated
                         "<twmr compiled kind>", "exec"), env)
            _HELD.append(env)
        _LOADED[kind.key] = tuple(_address(env[n]) if n in env else 0  # type: ignore[assignment]
                                  for n in ("ev", "st", "ad"))
        fresh += 1
    loops: tuple[Any, Any] = (driver_loop.run, driver_loop.finish)
    if not all(fn.overloads for fn in loops):  # (`signatures` hashes every type)
        for fn, sig in zip(loops, driver_loop.signatures(), strict=True):
            if not fn.signatures:
                cache = fn._cache
                cache.load_overload = schedule_cache.quick_loader(cache)
                fn.compile(sig)
                fresh += 1
    return {k.key: _LOADED[k.key] for k in kinds}, fresh


def held(kinds: Sequence[KindSpec]) -> bool:
    """Whether this process holds the adapters of every kind of `kinds` (and so has the driver
    compiled)."""
    return all(k.key in _LOADED for k in kinds)


def cached(kinds: Sequence[KindSpec], folder: Any) -> bool:
    """Whether every kind of `kinds` is ready without compiling: held by this process, or its
    machine code in numba's cache in `folder`."""
    from twmr.master import schedule_cache

    return all(k.key in _LOADED or schedule_cache.has_machine_code(*generate(k), folder, "kind")
               for k in kinds)
