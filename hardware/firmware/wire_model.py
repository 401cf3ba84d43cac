"""What a wire layout is (docs/DESIGN.md §5; hardware/firmware/wire.py declares them): a message's
fields in wire order, little-endian, packed, each a C type and count with PROTOCOL.md's words, the
firmware's source (what the robot sends) and how the dashboard takes it; at most one trailing
field repeated as often as a head field says (PARAMS, SET_PARAMS)."""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import Any, Literal

#: C type: (struct code, bytes, PROTOCOL.md's name, the host's Python type)
C_TYPES = {
    "uint8_t": ("B", 1, "u8", "int"),
    "int8_t": ("b", 1, "i8", "int"),
    "uint16_t": ("H", 2, "u16", "int"),
    "int16_t": ("h", 2, "i16", "int"),
    "uint32_t": ("I", 4, "u32", "int"),
    "float": ("f", 4, "f32", "float"),
}
_LVALUE = re.compile(r"[A-Za-z_]\w*((\.|->)[A-Za-z_]\w*)*")
#: how a linked robot's SENSORS field goes to the dashboard (app/firmware/robot_telemetry.py):
#: "" not as it is (a raw count the host decodes first), "value" as it is, "float32" as float32
#: decimals (a frame with one not finite is left out), "bits" as the names of the bits set
Dashboard = Literal["", "value", "float32", "bits"]


@dataclass(frozen=True)
class Field:
    """One field of a payload: `count` values of `ctype`. In a message the robot sends, taken in
    C from `source`: a variable or member of that type and size (its size is checked), or any
    other expression (a call, an upper-case macro) cast to `ctype` when `count` is 1. In one
    the host sends, `source` is empty: the firmware's `wire_unpack_<msg>` copies it out."""

    name: str  # the host's field name (app/firmware/wire_messages.py), and C's
    ctype: str
    count: int
    what: str  # PROTOCOL.md's words
    source: str = ""
    host: str = ""  # a type of app/firmware/wire_values.py the host reads it as (RunState)
    dashboard: Dashboard = ""

    def __post_init__(self) -> None:
        if self.ctype not in C_TYPES:
            raise ValueError(f"field {self.name}: C type {self.ctype!r}, not one of {[*C_TYPES]}")
        if self.count < 1:
            raise ValueError(f"field {self.name}: count {self.count}, must be 1 or more")

    @property
    def each(self) -> int:
        return C_TYPES[self.ctype][1]

    @property
    def size(self) -> int:
        return self.each * self.count

    @property
    def code(self) -> str:
        return f"{self.count if self.count > 1 else ''}{C_TYPES[self.ctype][0]}"

    def wire_type(self, times: str = "×") -> str:
        name = C_TYPES[self.ctype][2]
        return f"{self.count} {times} {name}" if self.count > 1 else name

    @property
    def is_lvalue(self) -> bool:
        """Whether `source` names a variable or member (its size is then checked in C); an
        upper-case name is a macro."""
        return _LVALUE.fullmatch(self.source) is not None and not self.source.isupper()


@dataclass(frozen=True)
class Layout:
    """A message's payload: its fields in wire order, little-endian, packed; `repeated` (its
    `count` the most) follows them, as many as the head field `count_field` says."""

    name: str  # PROTOCOL.md's message name, e.g. SENSORS
    type_code: int
    what: str  # the host's class docstring and PROTOCOL.md's caption
    fields: tuple[Field, ...]
    sender: Literal["robot", "host"] = "robot"
    includes: tuple[str, ...] = ()  # the firmware headers its sources need
    params: str = ""  # what `wire_pack_<name>` takes after `p`, when sources are a sender's locals
    repeated: Field | None = None
    count_field: str = ""
    answer: str = ""  # a request's: the message PROTOCOL.md answers it with

    def __post_init__(self) -> None:
        if (self.repeated is None) != (self.count_field == ""):
            raise ValueError(f"{self.name}: a repeated field needs its count_field, and only it")
        if self.count_field and self.count_field not in self.names:
            raise ValueError(f"{self.name}: count_field {self.count_field!r} is not a field")

    @property
    def size(self) -> int:
        """The bytes of the fixed fields (the head, where a field repeats)."""
        return sum(f.size for f in self.fields)

    @property
    def max_size(self) -> int:
        return self.size + (self.repeated.size if self.repeated else 0)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)

    @property
    def host_fields(self) -> tuple[Field, ...]:
        """The host's fields: the fixed ones but the count (the repeated field's length), then
        the repeated one."""
        return tuple(f for f in self.all_fields if f.name != self.count_field)

    @property
    def all_fields(self) -> tuple[Field, ...]:
        """The fixed fields, then the repeated one."""
        return self.fields + ((self.repeated,) if self.repeated is not None else ())

    @property
    def codec(self) -> struct.Struct:
        return struct.Struct("<" + "".join(f.code for f in self.fields))

    def offsets(self) -> list[int]:
        out, at = [], 0
        for f in self.fields:
            out.append(at)
            at += f.size
        return out

    def unpack(self, payload: bytes) -> dict[str, Any]:
        """{field name: value}, a tuple for a field of several values (the repeated one: as many
        as the count field says); struct.error if the payload is not that long."""
        values, out, at = self.codec.unpack_from(payload), dict[str, Any](), 0
        for f in self.fields:
            out[f.name] = tuple(values[at : at + f.count]) if f.count > 1 else values[at]
            at += f.count
        count: int = out[self.count_field] if self.repeated else 0
        if len(payload) != self.size + (self.repeated.each * count if self.repeated else 0):
            raise struct.error(f"{self.name} payload of {len(payload)} bytes")
        if self.repeated:
            code = f"<{count}{C_TYPES[self.repeated.ctype][0]}"
            out[self.repeated.name] = struct.unpack_from(code, payload, self.size)
        return out


@dataclass(frozen=True)
class Bare:
    """A message without payload: its name, type, what it does, and a request's answer."""

    name: str
    type_code: int
    what: str = ""
    answer: str = ""


Message = Layout | Bare
