"""The C twin of a block: what a block brings for a standalone C FMU, found through the registry.

A package registers each twin in the entry-point group `twmr.c_kernels` under the block's kind
(e.g. `gain = "twmr.blocks.ctwins:GAIN"`); the twin's C file lives beside the block. Real
parameters become FMI parameters (tunable when the kernel reads them at every step, else fixed);
the choices given by text or flags (a slip profile, a trajectory shape, a motor mode...) and the
sizes of a variable-size block are compiled into the FMU (`config.h`), so each FMU is one variant.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.registry import C_KERNELS, plugin, plugins, suggest


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


def twins() -> dict[str, str]:
    """Every registered C twin: kind -> 'module:attr'."""
    return plugins(C_KERNELS)


def twin_of(kind: str) -> CTwin:
    """The C twin registered for `kind`; CosimError naming the kinds that have one."""
    if kind not in twins():
        raise CosimError(f"kind '{kind}' has no C kernel for a standalone FMU"
                         f"{suggest(kind, twins())}; these have: {', '.join(sorted(twins()))}. "
                         f"Fix: export one of them, or use --python for a component of your own "
                         f"(a pythonfmu FMU).")
    twin = plugin(C_KERNELS, kind, "C twin")
    if not isinstance(twin, CTwin):
        raise CosimError(f"the C twin registered for '{kind}' ({twins()[kind]}) is not a "
                         f"CTwin. Fix: register a twmr.fmi.cexport.twin.CTwin in the entry-point "
                         f"group {C_KERNELS}.")
    return twin


def options_text(comp: Component, twin: CTwin) -> dict[str, Any]:
    """The text and integer parameters the FMU is compiled with (for its description)."""
    return {n: comp.get(n) for n, v in comp.parameters.items()
            if v.type != "Real" and n not in twin.hidden}
