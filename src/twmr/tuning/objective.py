"""What `twmr tune` searches and what it minimises: `--param NAME=SPEC` (the search space),
`--objective EXPR` (an expression of a run's metric figures, aggregated over the realisations)
and `--constraint "EXPR<=BOUND"` (held by every realisation).

SPEC: ``LO:HI`` or ``uniform:LO:HI``, ``log:LO:HI`` (log-uniform, 0 < LO), ``int:LO:HI``
(whole numbers) or ``values:A,B,C`` (a choice). EXPR: numbers, metric figure names (e.g.
``mse_x`` of the `tracking` set, ``ms_err_y`` of the `signals` set; ``base_mse_x`` a baseline
scenario's), ``+ - * / **``, comparisons ``< <= > >=`` (1 when true, else 0) and
``abs sqrt log exp min max``. The aggregate over the N realisations is ``mean``, ``median``,
``max`` or ``qP`` (the P-quantile, e.g. ``q0.9``); the spread is the realisations' standard
deviation.
"""
from __future__ import annotations

import ast
import math
import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twmr.sweeps.spec import SweepError, Vary, parse_vary


class TuneError(SweepError):
    """A tune that cannot be set up (a bad --param, --objective, --constraint or option)."""


PARAM_HINT = ("write NAME=LO:HI, log:LO:HI, int:LO:HI or values:A,B,C, e.g. "
              "--param ctrl.k=log:0.1:10")


@dataclass(frozen=True)
class Param:
    """One tuned override: NAME (component.parameter) and its range."""

    name: str
    kind: str  # 'float', 'log', 'int' or 'values'
    args: tuple[Any, ...]

    @property
    def text(self) -> str:
        if self.kind == "values":
            return "values:" + ",".join(str(a) for a in self.args)
        head = "" if self.kind == "float" else f"{self.kind}:"
        return head + ":".join(f"{a:g}" for a in self.args)

    def distribution(self) -> Any:
        """The Optuna distribution of this range."""
        from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

        if self.kind == "values":
            return CategoricalDistribution(list(self.args))
        if self.kind == "int":
            return IntDistribution(int(self.args[0]), int(self.args[1]))
        return FloatDistribution(self.args[0], self.args[1], log=self.kind == "log")

    def contains(self, value: Any) -> bool:
        """Whether `value` lies in this range (is one of its values; True is not 1)."""
        if self.kind == "values":
            return any(value == a and isinstance(value, bool) == isinstance(a, bool)
                       for a in self.args)
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if self.kind == "int" and not (isinstance(value, int) or float(value).is_integer()):
            return False
        low, high = self.args[0], self.args[1]
        return math.isfinite(value) and low <= value <= high

    def as_vary(self) -> Vary:
        """The same NAME as a sweep's Vary (for the scenario's name check)."""
        return Vary(self.name, "values", (0,))


def parse_param(text: str) -> Param:
    """`NAME=SPEC` as a Param; TuneError when it cannot be read."""
    name, sep, spec = str(text).partition("=")
    name, spec = name.strip(), spec.strip()
    if not sep:
        raise TuneError(f"--param {text!r}: cannot read it. Fix: {PARAM_HINT}.")
    if "[" in name:
        raise TuneError(f"--param {text!r}: elements of a vector cannot be tuned. Fix: tune a "
                        f"scalar parameter.")
    try:
        parse_vary(f"{name}=uniform:0:1", "--param")
    except SweepError:
        raise TuneError(f"--param {text!r}: '{name}' is not COMPONENT.PARAMETER. Fix: "
                        f"{PARAM_HINT}.") from None
    if spec.startswith("values:"):
        return Param(name, "values", parse_vary(f"{name}={spec}", f"--param {text!r}:").args)
    kind, parts = "float", spec.split(":")
    if parts[0] == "uniform":
        parts = parts[1:]
    elif parts[0] in ("log", "int"):
        kind, parts = parts[0], parts[1:]
    try:
        if len(parts) != 2:
            raise ValueError("give LO and HI")
        lo, hi = (float(p) for p in parts)
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValueError("LO and HI must be finite")
        if not lo < hi:
            raise ValueError(f"LO {lo:g} is not below HI {hi:g}")
        if kind == "log" and lo <= 0:
            raise ValueError(f"a log range starts above 0, not at {lo:g}")
        if kind == "int" and (lo != int(lo) or hi != int(hi)):
            raise ValueError("an int range has whole-number ends")
    except ValueError as err:
        raise TuneError(f"--param {text!r}: {err}. Fix: {PARAM_HINT}.") from None
    return Param(name, kind, (int(lo), int(hi)) if kind == "int" else (lo, hi))


_BINARY: dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.Pow: operator.pow}
_COMPARE: dict[type, Callable[[float, float], bool]] = {
    ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge}
_FUNCTIONS: dict[str, Callable[..., float]] = {
    "abs": abs, "sqrt": math.sqrt, "log": math.log, "exp": math.exp, "min": min, "max": max}
EXPR_HINT = ("write an expression of metric figures, numbers, + - * / **, < <= > >= and abs "
             "sqrt log exp min max, e.g. --objective 'mse_x + mse_y'")


class Expression:
    """An arithmetic expression of metric figure names, checked when read, evaluated on a
    run's figures."""

    def __init__(self, text: str, where: str = "--objective"):
        self.text = text
        try:
            self._tree = ast.parse(text.strip(), mode="eval").body
        except (SyntaxError, RecursionError, MemoryError):
            raise TuneError(f"{where} {text!r}: cannot read it. Fix: {EXPR_HINT}.") from None
        self.names: list[str] = []
        self._check(self._tree, where)
        called = {id(n.func) for n in ast.walk(self._tree) if isinstance(n, ast.Call)}
        for node in ast.walk(self._tree):  # a part of numbers alone must be a finite number
            if isinstance(node, ast.BinOp | ast.Call) and not any(
                    isinstance(n, ast.Name) and id(n) not in called for n in ast.walk(node)) \
                    and not math.isfinite(self.value({}, node)):
                raise TuneError(f"{where} {text!r}: '{ast.unparse(node)}' is not a finite "
                                f"number. Fix: {EXPR_HINT}.")

    def _check(self, node: ast.AST, where: str) -> None:
        if isinstance(node, ast.Name):
            if node.id not in self.names:
                self.names.append(node.id)
        elif isinstance(node, ast.Constant) and isinstance(node.value, int | float) and \
                not isinstance(node.value, bool):
            pass
        elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            self._check(node.left, where)
            self._check(node.right, where)
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            self._check(node.operand, where)
        elif isinstance(node, ast.Compare) and len(node.ops) == 1 and \
                type(node.ops[0]) in _COMPARE:
            self._check(node.left, where)
            self._check(node.comparators[0], where)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                node.func.id in _FUNCTIONS and node.args and not node.keywords:
            for arg in node.args:
                self._check(arg, where)
        else:
            raise TuneError(f"{where} {self.text!r}: '{ast.unparse(node)}' is not allowed in "
                            f"it. Fix: {EXPR_HINT}.")

    def value(self, figures: Mapping[str, Any], node: ast.AST | None = None) -> float:
        """The expression (or its part `node`) on one run's figures (nan where it is
        undefined, e.g. log of 0)."""
        try:
            return float(self._eval(self._tree if node is None else node, figures))
        except (ArithmeticError, ValueError, TypeError):
            return math.nan

    def _eval(self, node: ast.AST, env: Mapping[str, Any]) -> Any:
        if isinstance(node, ast.Name):
            return float(env[node.id])
        if isinstance(node, ast.Constant):
            # in floats: 9 ** 9 ** 9 overflows at once instead of computing a huge integer
            return float(node.value)  # type: ignore[arg-type]  # a number: `_check`
        if isinstance(node, ast.BinOp):
            return _BINARY[type(node.op)](self._eval(node.left, env),
                                          self._eval(node.right, env))
        if isinstance(node, ast.UnaryOp):
            value = self._eval(node.operand, env)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.Compare):
            return float(_COMPARE[type(node.ops[0])](self._eval(node.left, env),
                                                     self._eval(node.comparators[0], env)))
        assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
        return _FUNCTIONS[node.func.id](*(self._eval(a, env) for a in node.args))


_AGGREGATE = re.compile(r"^(mean|median|max|q(0(?:\.\d+)?|1(?:\.0*)?))$")


def aggregate(values: np.ndarray, how: str) -> float:
    """`how` (mean, median, max, qP) of the realisations' values."""
    if how == "mean":
        return float(np.mean(values))
    if how == "median":
        return float(np.median(values))
    if how == "max":
        return float(np.max(values))
    return float(np.quantile(values, float(how[1:])))


def check_aggregate(how: str) -> None:
    if not _AGGREGATE.match(how):
        raise TuneError(f"--aggregate {how!r} is unknown. Fix: use mean, median, max or qP, "
                        f"the P-quantile with 0 <= P <= 1 (e.g. q0.9).")


@dataclass
class Constraint:
    """`EXPR<=BOUND` or `EXPR>=BOUND`, to hold in every realisation."""

    text: str
    expression: Expression
    upper: bool
    bound: float

    def violation(self, values: np.ndarray) -> float:
        """How far the worst realisation is beyond the bound (<= 0: held by all)."""
        worst = np.max(values) if self.upper else np.min(values)
        return float(worst - self.bound if self.upper else self.bound - worst)


def parse_constraint(text: str) -> Constraint:
    """`EXPR<=BOUND` / `EXPR>=BOUND` as a Constraint; TuneError when it cannot be read."""
    hint = "write EXPR<=NUMBER or EXPR>=NUMBER, e.g. --constraint 'peak_error_x<=0.2'"
    m = re.match(r"^(.*?)(<=|>=)([^<>=]*)$", str(text).strip())
    if m is None:
        raise TuneError(f"--constraint {text!r}: no <= or >= in it. Fix: {hint}.")
    try:
        bound = float(m.group(3))
    except ValueError:
        raise TuneError(f"--constraint {text!r}: '{m.group(3).strip()}' is not a number. Fix: "
                        f"{hint}.") from None
    return Constraint(text, Expression(m.group(1), f"--constraint {text!r}:"),
                      m.group(2) == "<=", bound)


def unknown_names(names: list[str], figures: Mapping[str, Any], metrics: list[str]) -> str:
    """'' when every name is a figure of the run; else the one-paragraph complaint."""
    from twmr.registry import suggest

    missing = [n for n in names if n not in figures]
    if not missing:
        return ""
    known = sorted(k for k, v in figures.items() if isinstance(v, int | float))
    return (f"'{missing[0]}' is not a figure of the metric sets {', '.join(metrics)}"
            f"{suggest(missing[0], known)}. Fix: use one of {', '.join(known[:30])}"
            f"{', ...' if len(known) > 30 else ''}, or add the metric set that gives it "
            f"(--metrics).")
