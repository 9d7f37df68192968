"""A block's C twin, as its class declares it (`Component.c_twin`): the C file beside the block
and what a standalone C FMU of it compiles in (`twmr export KIND`, `twmr.fmi.cexport`). Real
parameters become FMI parameters (tunable when the kernel reads them at every step, else fixed);
the choices given by text or flags (a slip profile, a trajectory shape, a motor mode...) and the
sizes of a variable-size block are compiled into the FMU (`config.h`), so each FMU is one variant.
Light to import: every block module declares its twin.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import CosimError


@dataclass(frozen=True)
class Choice:
    """A parameter compiled in: `#define <define> codes[value]` in config.h."""

    define: str
    codes: Mapping[Any, int]


@dataclass(frozen=True)
class CTwin:
    """A block's C twin: its C file `source` (implementing kernel.h) and the headers it includes
    from beside it (`headers`, shipped in the FMU's sources too), the parameters it reads at
    every step (`tunable`), the parameters compiled in (`choices`), constants #defined for it
    (`defines`: codes shared with the Python side, taken from its constants); for a block of
    variable size, `order(comp)` its order n (CosimError for sizes that do not fit), #defined as
    `order_define`, `lengths` the length of each variable-size parameter for order n (an empty
    one is exported as n zeros) and `orders` the orders a test exercises; `work(comp)` the number
    of work values, `hidden` the parameters not exported, `pinned(comp)` the parameters whose
    export value decides the FMU's structure (its feedthrough): their min and max are that
    value; `sizes(comp)` further constants #defined from the instance (its tables' lengths, a
    sign pattern as a C initialiser)."""

    source: Path
    headers: tuple[Path, ...] = ()
    tunable: frozenset[str] = frozenset()
    choices: Mapping[str, Choice] = field(default_factory=dict)
    defines: Mapping[str, int] = field(default_factory=dict)
    order: Callable[[Component], int] | None = None
    order_define: str = "N"
    lengths: Mapping[str, Callable[[int], int]] = field(default_factory=dict)
    orders: tuple[int, ...] = ()
    work: Callable[[Component], int] = field(default=lambda comp: 1)
    hidden: frozenset[str] = frozenset()
    pinned: Callable[[Component], frozenset[str]] = field(default=lambda comp: frozenset())
    sizes: Callable[[Component], Mapping[str, int | str]] = field(default=lambda comp: {})

    def options(self, comp: Component) -> dict[str, int | str]:
        """The #defines of `comp`'s variant; CosimError for a value the twin does not support."""
        out: dict[str, int | str] = dict(self.defines)
        for name, choice in self.choices.items():
            value = comp.get(name)
            if value not in choice.codes:
                raise CosimError(
                    f"export {comp.kind}: {name} '{value}' has no C kernel. Fix: use {name} "
                    f"{' | '.join(map(str, choice.codes))}, or export with --python (a "
                    f"pythonfmu FMU that needs twmr-cosim where it runs).")
            out[choice.define] = choice.codes[value]
        if self.order is not None:
            out[self.order_define] = self.order(comp)
        out.update(self.sizes(comp))
        return out

    def fill_empty(self, comp: Component) -> None:
        """Give each empty variable-size parameter of `comp` its n zeros (n: its order)."""
        if self.order is None:
            return
        n = self.order(comp)
        for name, length in self.lengths.items():
            if not comp.get(name):
                comp.set_parameter(name, [0.0] * length(n))


# -- what twins of several blocks compute from an instance ------------------------------------
def checked(comp: Component) -> Component:
    """`comp`, its parameters checked as `twmr check` does (CosimError for the first problem)."""
    for _key, message, fix in comp.check(frozenset()):
        raise CosimError(f"export {comp.kind}: {message} Fix: {fix}")
    return comp


def width_of(comp: Component, name: str) -> int:
    """The number of elements of variable `name`."""
    return comp.variables[name].width


def initialiser(values: list[float] | list[int]) -> str:
    """A C array initialiser of `values`."""
    return "{" + ", ".join(map(repr, values)) + "}"


def nary_sizes(prefix: str, ops: str, alphabet: str
               ) -> Callable[[Component], dict[str, int | str]]:
    """#defines of a block combining n inputs by the signs/operations `ops` (a parameter whose
    characters are `alphabet`'s: the first +1, the other -1): <prefix>_N, _W and the signs."""
    def computed(comp: Component) -> dict[str, int | str]:
        signs = [1.0 if c == alphabet[0] else -1.0 for c in comp.get(ops)]
        return {f"{prefix}_N": len(signs), f"{prefix}_W": width_of(comp, "y"),
                f"{prefix}_{ops.upper()}": initialiser(signs)}
    return computed


def table_sizes(**lengths: str) -> Callable[[Component], dict[str, int]]:
    """#define -> the length of the table parameter named, after `comp.check` (an export of a
    table of the wrong shape or order is refused as a scenario is)."""
    def sizes(comp: Component) -> dict[str, int]:
        checked(comp)
        return {define: len(comp.get(name)) for define, name in lengths.items()}
    return sizes


def elements(comp: Component) -> int:
    """The number of elements n of an element-wise block (#defined as N)."""
    return int(comp.get("n"))


def elementwise(source: Path, **twin: Any) -> CTwin:
    """The twin of an element-wise block: its number of elements #defined as N."""
    return CTwin(source, order=elements, order_define="N", orders=(1, 3), **twin)
