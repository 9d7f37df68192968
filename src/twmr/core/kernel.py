"""The compiled form of a block: `Kernel`, and `kernel_function` to write its functions once.

A kernel is two pure functions of the block's private state x (a tuple, or a `NamedTuple`), its
outputs y (the tuple of its output and state ports, declared order), its inputs u (the tuple of
its input ports, declared order) and its parameters p (one `NamedTuple` per block, read by field
name):

    evaluate(t, x, y, u, p) -> (x, y)        # the feedthrough outputs at t (FMI: get after set)
    step(t, h, x, y, u, p) -> (x, y)         # advance from t to t + h [s] with u held

They are the block's definition: its Python `evaluate`/`do_step` run them
(`Component.kernel_evaluate`, `kernel_do_step`) and the compiled loop (`twmr.master.compiled`)
calls them, so both give the same numbers by construction. A function decorated with
`kernel_function` runs as plain Python (numba is not even imported) and is compiled by numba only
when compiled code calls it; a numba `@njit` function may be given as well (it then runs
compiled in Python too). A run long enough to repay loading numba (`compiled_pays`) calls its
blocks' kernel functions from Python in their `KernelFunction.python` form with compiled callees:
the work inside compiled, the block's tables and state handled by Python.
"""
from __future__ import annotations

import ast
import functools
import inspect
import sys
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from types import CodeType, FunctionType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from twmr.fmi.compiled_calls import FmuCalls

#: runs of at least this many steps repay loading numba (its import and machine code from its
#: cache: about half a second, more than a shorter run's Python steps)
AUTO_MIN_STEPS = 10_000


def compiled_pays(steps: float) -> bool:
    """Whether a run of `steps` steps repays loading numba to run compiled kernels (mode
    'auto' of `twmr.master.compiled`, and the Python forms of `KernelFunction.python`)."""
    return steps >= AUTO_MIN_STEPS


class KernelFunction:
    """A kernel function (see `kernel_function`): called from Python it runs `py_func` as plain
    Python; numba code that calls it (the generated loop, another kernel function) compiles it
    with `njit(cache=True, error_model='numpy')` on first use.

    Each one is an instance of a subclass of its own whose ``__call__`` is `py_func` itself, so
    a call from Python costs what a call of `py_func` does (one kernel function calling another
    runs at every step)."""

    py_func: Callable[..., Any]

    def __new__(cls, fn: Callable[..., Any]) -> KernelFunction:
        own = type(cls.__name__, (cls,), {"__call__": staticmethod(fn), "__slots__": (),
                                          "__module__": cls.__module__})
        return super().__new__(own)

    def __init__(self, fn: Callable[..., Any]):
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self._jit: Any = None
        self._forms: dict[bool, FunctionType] = {}

    def __call__(self, *args: Any) -> Any:  # replaced by `py_func` in each instance's class
        return self.py_func(*args)

    def __reduce__(self) -> str:
        # pickled by reference, as the module-level name it is (`functools.update_wrapper`)
        return str(self.__qualname__)  # type: ignore[attr-defined]

    @property
    def jit(self) -> Any:
        """The numba dispatcher of `py_func` (numba imported, and the function compiled, on first
        call)."""
        if self._jit is None:
            from numba import njit

            self._jit = njit(cache=True, error_model="numpy")(self.py_func)
        return self._jit

    def held(self) -> bool:
        """Whether this process has compiled the function (for some argument types)."""
        return self._jit is not None and bool(self._jit.signatures)

    def python(self, long: bool) -> Callable[..., Any]:
        """What a Python call of this function runs in a run that repays loading numba
        (`long`: `compiled_pays`; else only the kernel functions this process has compiled
        count): `py_func` calling each kernel function it names by its dispatcher when its
        arguments are ones numba types cheaply (`_Callee`), else in this form again, with the
        module's other globals as they are when the form is made (as numba freezes them); a
        short run with numba not imported: `py_func` itself."""
        if not long and "numba" not in sys.modules:
            return self.py_func
        form = self._forms.get(long)
        if form is None:
            fn = self.py_func
            names = dict(fn.__globals__)
            for name in _names(fn.__code__):
                if isinstance(names.get(name), KernelFunction):
                    names[name] = _Callee(names[name], names, name, long)
            form = self._forms[long] = FunctionType(fn.__code__, names, fn.__name__,
                                                    fn.__defaults__, fn.__closure__)
            functools.update_wrapper(form, fn)
        return form

    @property
    def _numba_type_(self) -> Any:
        """How numba types this object when compiled code refers to it: as its dispatcher."""
        from numba.core import types

        return types.Dispatcher(self.jit)

    def __deepcopy__(self, memo: dict[int, Any]) -> KernelFunction:
        return self

    def __repr__(self) -> str:
        return f"<kernel function {self.__module__}.{getattr(self, '__qualname__', '?')}>"


def _names(code: CodeType) -> set[str]:
    """The global names `code` and the code nested in it may load."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            names |= _names(const)
    return names


def _cheap(value: Any) -> bool:
    """Whether numba types `value` in C at a call: a float, int or bool, or a plain tuple of
    them (~0.2 us; a NamedTuple costs it ~1 us in Python, and as much again to return one)."""
    if type(value) is tuple:
        return all(_cheap(v) for v in value)
    return type(value) in (float, int, bool)


class _Callee:
    """Kernel function `kf` named `name` in the globals `names` of a `KernelFunction.python`
    form: at its first call replaced there by its dispatcher when the arguments are `_cheap`
    (and the run `long`, or the function compiled already) and numba compiles it for them,
    else by its own Python form."""

    def __init__(self, kf: KernelFunction, names: dict[str, Any], name: str, long: bool):
        self.kf, self.names, self.name, self.long = kf, names, name, long

    def __call__(self, *args: Any) -> Any:
        kf = self.kf
        if (self.long or kf.held()) and all(_cheap(a) for a in args):
            try:
                result = kf.jit(*args)
            except Exception:  # noqa: BLE001 - numba cannot compile it (or it failed): Python
                pass
            else:
                self.names[self.name] = kf.jit
                return result
        fn = self.names[self.name] = kf.python(self.long)
        return fn(*args)


def kernel_function(fn: Callable[..., Any]) -> KernelFunction:
    """Decorator of a kernel function (or a helper it calls), defined at module level: plain
    Python when called from Python, numba-compiled when called from compiled code. Write it in
    the subset of Python that numba compiles (floats, tuples, NamedTuples, math, numpy)."""
    return KernelFunction(fn)


@dataclass(frozen=True)
class Kernel:
    """A component's compiled form: the functions `evaluate(t, x, y, u, p) -> (x, y)` and
    `step(t, h, x, y, u, p) -> (x, y)` (either None; `kernel_function`s or numba functions), its
    parameter table `params` (a NamedTuple of floats, tuples of floats or numpy arrays) and its
    initial private state `state`, and `sync(x)`, called with the state after every chunk of
    compiled steps (and after every Python call that returns another state object) so the
    component can report (e.g. log a warning).

    `advance(t, h, x, y, u, p) -> (x, y)`, optional, is `step` without the work `evaluate` redoes
    at the next point: the same values of every output that depends on no input, the
    feedthrough outputs left as they were, and the same state x — for a block with feedthrough,
    the same once `evaluate` has run at the next point (a state `evaluate` sets, such as a
    controller's "the torque was limited", is left to it). The compiled driver and the Python
    schedule call it instead of `step` where the plan evaluates the block at the point after
    each step before anything reads its feedthrough outputs, except in the last step of a chunk
    (tests/property/test_block_forms.py holds it to `step`)."""

    params: tuple = ()
    state: tuple = ()
    evaluate: Any = None
    step: Any = None
    advance: Any = None
    sync: Callable[[Any], None] | None = None
    #: an FMU the loop calls itself through its C function pointers
    #: (`twmr.fmi.compiled_calls.FmuCalls`)
    fmu: FmuCalls | None = None

    def __deepcopy__(self, memo: dict[int, Any]) -> Kernel:
        return self  # immutable: a saved component state shares it


#: (function, parameter index, shape of the table) -> whether the function only reads fields
_READS_FIELDS: dict[tuple[Any, int, Any], bool] = {}
_VIEWS: dict[type, type] = {}


def _is_table(value: Any) -> bool:
    return isinstance(value, tuple) and hasattr(type(value), "_fields")


def _shape(table: Any) -> Any:
    """The type of a table and of the tables it nests (what the field reads depend on)."""
    return (type(table), tuple(_shape(v) if _is_table(v) else None for v in table))


def python_params(params: Any, functions: tuple[Callable[..., Any] | None, ...]) -> Any:
    """`params` as the Python forms of a kernel's functions `functions` (evaluate, step,
    advance: their last argument) are given it: a parameter table (a NamedTuple, nested ones
    too) as an object with the same fields in slots, whose fields CPython reads several times
    faster, when the source of each `kernel_function` shows that it only reads fields of the
    table, by name (``p.k``) or by handing the table or a nested one to another
    `kernel_function` that does; else (a numba function among them too) `params` as it is. The
    values are the same objects, so the results are too."""
    if not _is_table(params):
        return params
    for fn in functions:
        py = fn.py_func if isinstance(fn, KernelFunction) else fn
        if py is not None and not _reads_fields(py, -1, params, set()):
            return params
    return _view(params)


def _view(table: Any) -> Any:
    cls = _VIEWS.get(type(table))
    if cls is None:
        cls = _VIEWS[type(table)] = type(f"{type(table).__name__}Fields", (),
                                         {"__slots__": type(table)._fields})
    view = cls()
    for name, value in zip(type(table)._fields, table, strict=True):
        setattr(view, name, _view(value) if _is_table(value) else value)
    return view


def _reads_fields(fn: Callable[..., Any], index: int, table: Any, busy: set[Any]) -> bool:
    """Whether plain function `fn` uses its positional parameter `index` (holding `table`) only
    to read fields of it (see `python_params`); unknown (no source, other uses): False."""
    key = (fn, index, _shape(table))
    if key in _READS_FIELDS:
        return _READS_FIELDS[key]
    if key in busy or not isinstance(fn, FunctionType):  # recursion, numba: not shown
        return False
    busy.add(key)
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    except (OSError, TypeError, SyntaxError):
        _READS_FIELDS[key] = False
        return False
    func = tree.body[0] if tree.body else None
    ok = False
    if isinstance(func, ast.FunctionDef):
        positional = [*func.args.posonlyargs, *func.args.args]
        ok = -len(positional) <= index < len(positional)
    if ok and isinstance(func, ast.FunctionDef):
        name = positional[index].arg
        nodes = list(ast.walk(func))
        parents = {child: node for node in nodes for child in ast.iter_child_nodes(node)}
        bound = {n.id for n in nodes if isinstance(n, ast.Name) and
                 not isinstance(n.ctx, ast.Load)} | {a.arg for a in nodes
                                                     if isinstance(a, ast.arg)}
        ok = all(_field_read(node, table, parents, bound, fn.__globals__, busy)
                 for node in nodes if isinstance(node, ast.Name) and node.id == name)
    _READS_FIELDS[key] = ok
    return ok


def _field_read(node: ast.expr, table: Any, parents: dict[ast.AST, ast.AST], bound: set[str],
                names: dict[str, Any], busy: set[Any]) -> bool:
    """Whether expression `node` (holding `table`) is only read from: a field of it (a nested
    table read the same way), or a positional argument of a `kernel_function` called by its
    global name that reads it so."""
    parent = parents.get(node)
    if isinstance(parent, ast.Attribute) and parent.value is node:
        if not isinstance(parent.ctx, ast.Load) or parent.attr not in type(table)._fields:
            return False
        value = getattr(table, parent.attr)
        return not _is_table(value) or _field_read(parent, value, parents, bound, names, busy)
    if isinstance(parent, ast.Call) and isinstance(parent.func, ast.Name) and \
            parent.func.id not in bound and any(a is node for a in parent.args):
        position = next(i for i, a in enumerate(parent.args) if a is node)
        callee = names.get(parent.func.id)
        if isinstance(callee, KernelFunction) and not any(
                isinstance(a, ast.Starred) for a in parent.args[:position]):
            return _reads_fields(callee.py_func, position, table, busy)
    return False


__all__ = ["AUTO_MIN_STEPS", "Kernel", "KernelFunction",
           "compiled_pays", "kernel_function", "python_params"]


class Carriage(str, Enum):
    """How the compiled loop holds a port's value."""

    FLOAT = "f"  # float64
    INT = "i"  # int64
    UINT = "u"  # uint64, wrapped into its range
    BOOL = "b"  # an int64 that is a bool in Python (an FMI 3.0 Boolean)
    NONE = "x"  # not at all: a String, Binary or Clock port the run neither sets nor reads
