"""The one interface every CAN drive protocol implements, and the protocols by name.

A `Link` is the host side of a drive pair on one python-can bus: open it, `start` (configure and
enable every axis), `command` torques each period, read `feedback` and `heartbeats`, latch a
`fault`, `disable` and `close`. The same class says what replay and the emulator need: `decode`
reads one of its frames back to SI values, `emulate` starts emulated drives that answer its
frames. `protection()` says which drives stop by themselves when the host falls silent.

Protocols are registered through the entry-point group `twmr.can_protocols` (name ->
`module:LinkClass`); `protocol(name)` loads one, `protocols()` lists them without importing.
The drive block, safety, replay and the CLI see nothing but this interface and the registry.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import Field, dataclass, field, fields
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

from twmr.core.port import BOOLEAN, INTEGER, REAL, STRING, Parameter

if TYPE_CHECKING:
    import can

    from twmr.hw.bus import FrameLog
    from twmr.hw.safety import Fault

#: (node or None for the bus, signal, value) of one decoded frame
Signals = list[tuple[int | None, str, float]]


def option(default: Any, *, unit: str = "", description: str = "", min: float | None = None,
           file: bool = False) -> Any:
    """A field of a protocol's `Link.Options`: its default, unit, description and minimum
    (the drive blocks offer it as a parameter with these); `file`: a path that resolves against
    the scenario's folder."""
    return field(default=default, metadata={"unit": unit, "description": description,
                                            "min": min, "file": file})


#: how long a stop waits for each drive to confirm it (its heartbeat or statusword) [s], and how
#: often it sends the stop again meanwhile [s]
STOP_CONFIRM_S, STOP_RESEND_S = 0.5, 0.1


@dataclass(frozen=True)
class NoOptions:
    """A protocol without options of its own."""


@dataclass(frozen=True)
class DriveSpec:
    """What every drive has, whatever its protocol (SI units at the wheel), and the protocol's
    own options (`options`, an instance of its `Link.Options`)."""

    nodes: tuple[int, ...] = (0, 1)
    gear: float = 1.0  # motor turns per wheel turn
    torque_limit: float = 50.0  # |wheel torque| [N.m]
    heartbeat_timeout: float = 0.5  # [s]
    options: Any = NoOptions()

    @classmethod
    def of(cls, link: type[Link], source: Any, **given: Any) -> DriveSpec:
        """The spec of `link`'s drives from the attributes of `source` named as the common
        fields and the fields of `link.Options` (a drive block's parameters, a command's
        arguments, a decoder's settings: the one place a spec is built), each converted to its
        field's type; `given` overrides or adds fields. Fields `source` lacks keep their
        defaults."""
        common = _values([f for f in fields(cls) if f.name != "options"], source, given)
        return cls(**common, options=link.Options(**_values(fields(link.Options), source, given)))


def _values(wanted: Sequence[Field[Any]], source: Any, given: Mapping[str, Any]
            ) -> dict[str, Any]:
    values: dict[str, Any] = {}
    for f in wanted:
        if f.name in given:
            values[f.name] = given[f.name]
        elif getattr(source, f.name, None) is not None:
            value = getattr(source, f.name)
            kind: Any = type(f.default)
            values[f.name] = tuple(int(n) for n in value) if kind is tuple else kind(value)
    return values


def option_parameters(options: type) -> dict[str, Parameter]:
    """A protocol's `Options` as drive-block parameters (type from the default, unit,
    description, minimum), by name."""
    out: dict[str, Parameter] = {}
    for f in fields(options):
        meta = f.metadata
        kind = {bool: BOOLEAN, int: INTEGER, str: STRING}.get(type(f.default), REAL)
        var = Parameter(f.default, type=kind, unit=meta.get("unit", ""),
                        min=meta.get("min"), description=meta.get("description", ""))
        var.name = f.name
        out[f.name] = var
    return out


def option_files(options: type) -> tuple[str, ...]:
    """The fields of a protocol's `Options` that name files (resolved against the scenario's
    folder)."""
    return tuple(f.name for f in fields(options) if f.metadata.get("file"))


class Emulator(Protocol):
    """Emulated drives answering a link's frames (a thread of their own)."""

    axes: Mapping[int, Any]

    def set_load_speeds(self, speeds: Mapping[int, float]) -> None: ...

    def applied(self) -> dict[int, float]:
        """The wheel torque [N.m] each axis applies now, by node."""
        ...

    def close(self) -> None: ...


class Link(ABC):
    """The host side of one protocol's drives `spec.nodes` (wheel order) on bus `options`."""

    #: node ids the protocol can address, and the ids `twmr emulate-drive` uses by default
    node_range: ClassVar[range]
    default_nodes: ClassVar[tuple[int, int]]
    #: the protocol's own options (a frozen dataclass whose fields are made with `option`):
    #: parameters of the drive blocks that use it, `DriveSpec.options` of its links
    Options: ClassVar[type] = NoOptions
    #: the protocol's host side in C for a controller FMU on a CAN terminal (`twmr export KIND
    #: --fmi 3 --can NAME`, twmr.fmi.cexport.busnode.CNode), or None
    c_node: ClassVar[Any] = None
    #: the units of the signals `decode` gives (at the wheel, SI): '' for a count or a code
    signal_units: ClassVar[dict[str, str]] = {}
    fault: Fault | None
    fault_at: float  # time.perf_counter() when `fault` was latched (nan: none)
    rtt_ns: list[int]

    @abstractmethod
    def __init__(self, spec: DriveSpec, options: dict[str, Any], log: FrameLog | None = None):
        """Open the bus; `LinkError` when it cannot be opened."""

    @classmethod
    def check(cls, spec: DriveSpec) -> list[tuple[str, str, str]]:
        """Problems of the protocol's own parameters (parameter, what, fix), before any I/O."""
        return []

    @classmethod
    def node_problem(cls, nodes: Sequence[int]) -> str:
        """'' when `nodes` are distinct and addressable, else what is wrong."""
        bad = [n for n in nodes if n not in cls.node_range]
        if bad:
            return (f"node id {bad[0]} is outside {cls.node_range.start}.."
                    f"{cls.node_range.stop - 1}, the node ids of this protocol")
        if len(set(nodes)) != len(nodes):
            return f"node ids {list(nodes)} repeat: one drive would get both wheels' torque"
        return ""

    @classmethod
    @abstractmethod
    def decode(cls, msg: can.Message, spec: DriveSpec) -> Signals:
        """What one frame of this protocol carries, in SI; [] for frames it does not know.
        Raises ValueError/struct.error for a frame too short for its identifier."""

    @classmethod
    @abstractmethod
    def emulate(cls, spec: DriveSpec, options: dict[str, Any]) -> tuple[Emulator, DriveSpec]:
        """Emulated drives `spec.nodes` answering on bus `options`, and the spec the host
        reaches them with."""

    @abstractmethod
    def start(self, timeout: float) -> None:
        """Configure and enable every axis within `timeout` [s]; `LinkError` otherwise."""

    @abstractmethod
    def command(self, torques: Sequence[float]) -> tuple[float, ...]:
        """Send wheel torques [N.m]; the torques the drives receive (wire quantisation)."""

    @abstractmethod
    def wait_feedback(self, timeout: float) -> bool:
        """Wait up to `timeout` [s] for this period's feedback (True when it all came)."""

    @abstractmethod
    def feedback(self) -> list[tuple[float, float, float]]:
        """(wheel angle [rad], wheel speed [rad/s], monotonic time of its frame) per axis."""

    @abstractmethod
    def heartbeats(self) -> dict[int, float]:
        """Monotonic time of each drive's last heartbeat, by node."""

    @abstractmethod
    def protection(self) -> dict[int, tuple[bool, str]]:
        """Per node: whether the drive stops by itself when the host falls silent, and how
        (or why not)."""

    @abstractmethod
    def disable(self, emergency: bool = False) -> list[int]:
        """Zero torque, then disable every axis (the emergency form after a fault); the nodes
        whose drives did not confirm it (empty where the protocol has no confirmation)."""

    @abstractmethod
    def close(self) -> None:
        """Close the bus (after `disable`)."""


def protocols() -> list[str]:
    """The registered protocol names (nothing imported)."""
    from twmr.registry import CAN_PROTOCOLS, plugins

    return sorted(plugins(CAN_PROTOCOLS))


def protocol(name: str) -> type[Link]:
    """The `Link` class registered as `name`; CosimError naming the known ones otherwise."""
    from twmr.registry import CAN_PROTOCOLS, plugin

    link = plugin(CAN_PROTOCOLS, name, "CAN protocol")
    if not (isinstance(link, type) and issubclass(link, Link)):
        from twmr.core.errors import CosimError

        raise CosimError(f"CAN protocol '{name}' is registered as {link!r}, not a Link class. "
                         f"Fix: register a subclass of twmr.hw.link.Link under twmr.can_protocols.")
    return link
