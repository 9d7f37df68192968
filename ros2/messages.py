"""ROS 2 message types as DDS types: the definitions of `rosbags`' type store made into
cyclonedds structs with ROS 2's names (`geometry_msgs/msg/Twist` ->
`geometry_msgs::msg::dds_::Twist_`), topic names mangled as ROS 2 does (`/cmd_vel` ->
`rt/cmd_vel`), and the numeric leaf fields of a message (`linear.x`, `pose.pose.position.x`,
`covariance[0]`) as the paths ports read and write."""
from __future__ import annotations

import functools
import re
from typing import Any

#: ROS 2 base types -> cyclonedds field types (ROS 2's IDL: byte is an octet, char a uint8)
_BASE = ("bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
         "uint64", "float32", "float64", "string", "wstring")
NUMERIC = frozenset(_BASE) - {"string", "wstring"}
#: how many elements of a fixed array become ports at most (a 36-element covariance: all)
MAX_ARRAY_PORTS = 64


class MessageError(ValueError):
    """A message type, field or name that cannot be used, with the closest known one."""


@functools.cache
def typestore(distro: str = "humble") -> Any:
    """rosbags' type store of a ROS 2 distribution ('humble', 'jazzy', ...)."""
    from rosbags.typesys import Stores, get_typestore

    name = f"ROS2_{distro.upper()}"
    if name not in Stores.__members__:
        known = ", ".join(s[5:].lower() for s in Stores.__members__ if s.startswith("ROS2_"))
        raise MessageError(f"unknown ROS 2 distribution '{distro}' (known: {known})")
    return get_typestore(Stores[name])


def check_type(type_name: str, distro: str = "humble") -> None:
    """MessageError when `type_name` ('pkg/msg/Name') is not in the distribution's store."""
    from twmr.registry import suggest

    store = typestore(distro)
    if type_name not in store.fielddefs:
        raise MessageError(f"unknown message type '{type_name}'"
                           f"{suggest(type_name, sorted(store.fielddefs))} (rosbags' {distro} "
                           f"type store; a type of your own is not supported yet)")


def dds_type_name(type_name: str) -> str:
    """'geometry_msgs/msg/Twist' -> 'geometry_msgs::msg::dds_::Twist_' (ROS 2's mangling)."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def dds_topic_name(topic: str, namespace: str = "") -> str:
    """'/cmd_vel' (namespace '/robot1') -> 'rt/robot1/cmd_vel': ROS 2's topic prefix; a name
    without a leading '/' is relative to the namespace. MessageError for an invalid name."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    full = topic if topic.startswith("/") else f"{ns}/{topic}"
    if not re.fullmatch(r"(/[A-Za-z_][A-Za-z0-9_]*)+", full):
        raise MessageError(f"'{full}' is not a ROS 2 topic name (tokens of letters, digits and "
                           f"underscores, each not starting with a digit, joined by '/')")
    return "rt" + full


def _field_type(node: tuple, distro: str) -> Any:
    from cyclonedds.idl import types as idl_types
    from rosbags.typesys.base import Nodetype

    types: Any = idl_types  # its generics are indexed through a metaclass

    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        if name in ("string", "wstring"):
            return types.bounded_str[bound] if bound else str
        if name == "bool":
            return bool
        return {"byte": types.byte, "char": types.uint8}.get(name) or getattr(types, name)
    if kind == Nodetype.NAME:
        return dds_struct(detail, distro)
    inner, size = detail
    if kind == Nodetype.ARRAY:
        return types.array[_field_type(inner, distro), size]
    return types.sequence[_field_type(inner, distro), size] if size else \
        types.sequence[_field_type(inner, distro)]


@functools.cache
def dds_struct(type_name: str, distro: str = "humble") -> Any:
    """The cyclonedds struct of a ROS 2 message type, named as ROS 2 names it on the wire."""
    from cyclonedds.idl import make_idl_struct

    check_type(type_name, distro)
    _, fields = typestore(distro).fielddefs[type_name]
    if not fields:  # an empty message carries one uint8 in ROS 2's IDL
        from cyclonedds.idl import types

        members: dict[str, Any] = {"structure_needs_at_least_one_member": types.uint8}
    else:
        members = {name: _field_type(node, distro) for name, node in fields}
    return make_idl_struct(type_name.replace("/", "_"), dds_type_name(type_name), members)


def leaf_fields(type_name: str, distro: str = "humble", prefix: str = ""
                ) -> list[tuple[str, int]]:
    """(path, size) of the numeric leaf fields of a message ('linear.x', 1;
    'pose.covariance', 36), in the order of the definition: a fixed array of numbers is one
    field of its size; sequences and strings are left out (a port has a fixed size)."""
    from rosbags.typesys.base import Nodetype

    out: list[tuple[str, int]] = []
    for name, (kind, detail) in typestore(distro).fielddefs[type_name][1]:
        path = f"{prefix}{name}"
        if kind == Nodetype.BASE and detail[0] in NUMERIC:
            out.append((path, 1))
        elif kind == Nodetype.NAME:
            out += leaf_fields(detail, distro, f"{path}.")
        elif kind == Nodetype.ARRAY and detail[0][0] == Nodetype.BASE and \
                detail[0][1][0] in NUMERIC and detail[1] <= MAX_ARRAY_PORTS:
            out.append((path, detail[1]))
    return out


def sequence_fields(type_name: str, distro: str = "humble", prefix: str = "") -> list[str]:
    """Paths of the sequences of numbers of a message ('position', 'velocity'): a port of a
    size given in `fields:` ('velocity:2') reads or writes their first elements."""
    from rosbags.typesys.base import Nodetype

    out: list[str] = []
    for name, (kind, detail) in typestore(distro).fielddefs[type_name][1]:
        if kind == Nodetype.SEQUENCE and detail[0][0] == Nodetype.BASE and \
                detail[0][1][0] in NUMERIC:
            out.append(f"{prefix}{name}")
        elif kind == Nodetype.NAME:
            out += sequence_fields(detail, distro, f"{prefix}{name}.")
    return out


def time_fields(type_name: str, distro: str = "humble", prefix: str = "") -> list[str]:
    """Paths of the builtin_interfaces/msg/Time fields of a message ('header.stamp',
    'clock'), outermost first."""
    from rosbags.typesys.base import Nodetype

    out: list[str] = []
    for name, (kind, detail) in typestore(distro).fielddefs[type_name][1]:
        if kind == Nodetype.NAME:
            if detail == "builtin_interfaces/msg/Time":
                out.append(f"{prefix}{name}")
            else:
                out += time_fields(detail, distro, f"{prefix}{name}.")
    return out


def default_message(type_name: str, distro: str = "humble") -> Any:
    """A message of the type with every field zero, empty or false."""
    from rosbags.typesys.base import Nodetype

    def value(node: tuple) -> Any:
        kind, detail = node
        if kind == Nodetype.BASE:
            return "" if detail[0] in ("string", "wstring") else \
                (False if detail[0] == "bool" else 0 if "int" in detail[0] or detail[0] in (
                    "byte", "char") else 0.0)
        if kind == Nodetype.NAME:
            return default_message(detail, distro)
        if kind == Nodetype.ARRAY:
            return [value(detail[0]) for _ in range(detail[1])]
        return []

    cls = dds_struct(type_name, distro)
    _, fields = typestore(distro).fielddefs[type_name]
    if not fields:
        return cls(structure_needs_at_least_one_member=0)
    return cls(**{name: value(node) for name, node in fields})


def _walk(message: Any, path: str) -> tuple[Any, str]:
    """(the object holding the last field of `path`, that field's name)."""
    parts = path.split(".")
    holder = message
    for part in parts[:-1]:
        holder = getattr(holder, part)
    return holder, parts[-1]


def get_field(message: Any, path: str) -> float | tuple[float, ...]:
    """The number (or the numbers of a fixed array) at `path` ('pose.pose.position.x')."""
    holder, name = _walk(message, path)
    value = getattr(holder, name)
    if isinstance(value, (list, tuple)):
        return tuple(float(v) for v in value)
    return float(value)


def set_field(message: Any, path: str, value: Any) -> None:
    """Set the field at `path` to `value` (a number, a tuple for a fixed array, or text for a
    string field), each number made the field's type (an integer field rounded)."""
    holder, name = _walk(message, path)
    old = getattr(holder, name)

    def like(example: Any, number: Any) -> Any:
        if isinstance(example, bool):  # a constant's text: 'true', '1', 'yes'
            return number.strip().lower() in ("1", "true", "yes") if isinstance(number, str) \
                else bool(number)
        if isinstance(example, int):
            return round(float(number))
        return float(number)

    if isinstance(old, str):
        setattr(holder, name, str(value))
    elif isinstance(value, str) and isinstance(old, list):  # a sequence of strings: 'a|b'
        setattr(holder, name, value.split("|") if value else [])
    elif isinstance(old, (list, tuple)) and len(old) == len(value):
        setattr(holder, name, [like(o, v) for o, v in zip(old, value, strict=True)])
    elif isinstance(old, list):  # a sequence, as long as the port
        setattr(holder, name, [float(v) for v in value])
    else:
        setattr(holder, name, like(old, value))


def set_time(message: Any, path: str, t: float) -> None:
    """A builtin_interfaces/msg/Time field at `path` set to `t` [s] (sec and nanosec)."""
    holder, name = _walk(message, path)
    stamp = getattr(holder, name)
    ns = round(t * 1e9)
    stamp.sec, stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
