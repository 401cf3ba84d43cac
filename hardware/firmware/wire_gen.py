"""What hardware/firmware/wire.py's layouts generate (docs/DESIGN.md §5): the firmware's
`artro_wire.h` (offsets, `wire_pack_<msg>` of what the robot sends, `wire_unpack_<msg>` of what
the host sends), PROTOCOL.md's tables and the host's app/firmware/wire_messages.py (a dataclass
with `unpack` per reply, a `pack_<msg>` per request)."""

from __future__ import annotations

import textwrap
from collections.abc import Sequence

from hardware.firmware.wire_model import C_TYPES, Field, Layout, Message

#: Field.host: (the host's annotation, its converter in app/firmware/wire_values.py)
HOST_TYPES = {"RunState": ("RunState", "run_state"), "NakReason": ("NakReason | int", "nak_reason")}


def _c_name(layout: Layout, *parts: str) -> str:
    return "_".join(["ARTRO_WIRE", layout.name, *(p.upper() for p in parts)])


def _c_defines(layout: Layout) -> list[str]:
    lines = [f"/* ---- {layout.name} (0x{layout.type_code:02X}) ---- */"]
    lines.append(f"#define {_c_name(layout, 'BYTES')} {layout.size}u")
    for f, at in zip(layout.fields, layout.offsets(), strict=True):
        lines.append(f"#define {_c_name(layout, f.name):<40} {at}u /* {f.wire_type('x')} */")
    if (rep := layout.repeated) is not None:
        count = layout.count_field
        lines += [
            f"#define {_c_name(layout, rep.name):<40} {layout.size}u /* {count} x "
            f"{C_TYPES[rep.ctype][2]} */",
            f"#define {_c_name(layout, 'MAX_BYTES')} {layout.max_size}u",
            f"#define {_c_name(layout, 'BYTES_OF')}({count}) "
            f"({_c_name(layout, 'BYTES')} + {rep.each}u * ({count}))",
        ]
    return lines


def _c_pack(layout: Layout) -> list[str]:
    lower, rep = layout.name.lower(), layout.repeated
    params = f", {layout.params}" if layout.params else ""
    returns = "uint8_t" if rep else "void"
    said = "; its length" if rep else ""
    lines = [
        f"/* the payload of {layout.name} from the firmware's state, into "
        f"p[{_c_name(layout, 'MAX_BYTES' if rep else 'BYTES')}]{said} */",
        f"static inline {returns} wire_pack_{lower}(uint8_t *p{params})",
        "{",
    ]
    for f in layout.fields:
        if f.is_lvalue:
            lines.append(
                f'    _Static_assert(sizeof({f.source}) == {f.size}, "{f.source} is not '
                f"{layout.name}'s {f.wire_type('x')} {f.name} (hardware/firmware/wire.py)\");"
            )
    for f in layout.all_fields:
        offset = _c_name(layout, f.name)
        if f is rep:
            count = next(c.source for c in layout.fields if c.name == layout.count_field)
            lines.append(f"    memcpy(&p[{offset}], {f.source}, {f.each}u * ({count}));")
            lines.append(f"    return (uint8_t){_c_name(layout, 'BYTES_OF')}({count});")
        elif f.count > 1:
            lines.append(f"    memcpy(&p[{offset}], {f.source}, {f.size});")
        elif f.size == 1:
            lines.append(f"    p[{offset}] = (uint8_t)({f.source});")
        else:
            lines.append(f"    {{ const {f.ctype} v = ({f.ctype})({f.source});")
            lines.append(f"      memcpy(&p[{offset}], &v, {f.size}); }}")
    return [*lines, "}"]


def _c_unpack(layout: Layout) -> list[str]:
    rep, fields = layout.repeated, layout.all_fields
    params = ", ".join(f"{f.ctype} *{f.name}" for f in fields)
    lines = [
        f"/* the fields of {layout.name} out of its payload p (its length checked before) */",
        f"static inline void wire_unpack_{layout.name.lower()}(const uint8_t *p, {params})",
        "{",
    ]
    for f in fields:
        offset = _c_name(layout, f.name)
        if f is rep:
            count = f"p[{_c_name(layout, layout.count_field)}]"
            lines.append(f"    memcpy({f.name}, &p[{offset}], {f.each}u * {count});")
        elif f.size == 1:
            lines.append(f"    *{f.name} = ({f.ctype})p[{offset}];")
        else:
            lines.append(f"    memcpy({f.name}, &p[{offset}], {f.size});")
    return [*lines, "}"]


def _c_types(messages: Sequence[Message]) -> list[str]:
    lines = []
    for sender, first in (("host -> robot", True), ("robot -> host", False)):
        lines += ["", f"/* message types, {sender} */", "enum {"]
        for m in messages:
            if (m.type_code < 0x80) == first:
                said = f" /* -> {m.answer} */" if m.answer else ""
                lines.append(f"    MSG_{m.name} = 0x{m.type_code:02X},{said}")
        lines.append("};")
    return lines


def c_wire_header(messages: Sequence[Message], layouts: Sequence[Layout], header_name: str) -> str:
    """The include-guarded header: the message types (`MSG_<NAME>`), per layout its size, each
    field's offset (`ARTRO_WIRE_<MSG>_<FIELD>`), and `wire_pack_<msg>` (the robot's, its
    sources' sizes checked) or `wire_unpack_<msg>` (the host's)."""
    includes = sorted({name for layout in layouts for name in layout.includes})
    lines = [
        f"/* {header_name} -- the payloads of PROTOCOL.md's fixed-layout messages.",
        " * Generated from hardware/firmware/wire.py; do not edit by hand. */",
        "#ifndef ARTRO_WIRE_H",
        "#define ARTRO_WIRE_H",
        "",
        "#include <stdint.h>",
        "#include <string.h>",
        "",
        *(f'#include "{name}"' for name in includes),
        *_c_types(messages),
    ]
    for layout in layouts:
        code = _c_pack(layout) if layout.sender == "robot" else _c_unpack(layout)
        lines += ["", *_c_defines(layout), *code]
    return "\n".join([*lines, "", "#endif /* ARTRO_WIRE_H */"]) + "\n"


def _md(text: str) -> str:
    return text.replace("|", "\\|")


def _payload_words(m: Message) -> str:
    """A message's payload in a summary row: its fields' names and types, or what it does."""
    if not isinstance(m, Layout):
        return f"– ({m.what})" if m.what else "–"
    if len(m.fields) > 5:
        return f"{m.what}: the table below"
    words = [f"{f.name} {f.wire_type()}" for f in m.fields]
    if m.repeated:
        words.append(f"{m.repeated.name} {m.count_field} × {C_TYPES[m.repeated.ctype][2]}")
    return ", ".join(words)


def protocol_tables(messages: Sequence[Message]) -> str:
    """PROTOCOL.md's generated part: the messages each way (type, name, payload, a request's
    answer), then one table per layout, each field's offset, type, meaning."""
    host = [m for m in messages if m.type_code < 0x80]
    parts = [
        "## Host → robot\n\n| type | name | payload | answer |\n|---|---|---|---|\n"
        + "\n".join(
            f"| 0x{m.type_code:02X} | {m.name} | {_md(_payload_words(m))} | {m.answer} |"
            for m in host
        ),
        "## Robot → host\n\n| type | name | payload |\n|---|---|---|\n"
        + "\n".join(
            f"| 0x{m.type_code:02X} | {m.name} | {_md(_payload_words(m))} |"
            for m in messages
            if m.type_code >= 0x80
        ),
        "## Payloads\n\nEach message's payload: each field's offset, its type and what it holds.",
    ]
    for layout in (m for m in messages if isinstance(m, Layout)):
        rep = layout.repeated
        size = f"{layout.size} + {rep.each} × {layout.count_field}" if rep else f"{layout.size}"
        size += " byte" if size == "1" else " bytes"
        rows = [
            f"**{layout.name}** (0x{layout.type_code:02X}), {size}, {_md(layout.what)}:",
            "",
            "| offset | field | type | what |",
            "|---|---|---|---|",
        ]
        rows += [
            f"| {at} | {f.name} | {f.wire_type()} | {_md(f.what)} |"
            for f, at in zip(layout.fields, layout.offsets(), strict=True)
        ]
        if rep:
            kind = f"{layout.count_field} × {C_TYPES[rep.ctype][2]}"
            rows.append(f"| {layout.size} | {rep.name} | {kind} | {_md(rep.what)} |")
        parts.append("\n".join(rows))
    return "\n\n".join(parts) + "\n"


# ---- the host's module ----------------------------------------------------------------------


def _py_type(f: Field, *, repeated: bool = False) -> str:
    if f.host:
        return HOST_TYPES[f.host][0]
    base = C_TYPES[f.ctype][3]
    if repeated or f.count > 4:
        return f"tuple[{base}, ...]"
    return f"tuple[{', '.join([base] * f.count)}]" if f.count > 1 else base


def _comment(text: str, indent: str) -> list[str]:
    return textwrap.wrap(text, 99 - len(indent), initial_indent=indent + "#: ",
                         subsequent_indent=indent + "#: ")  # fmt: skip


def _py_reply(layout: Layout) -> list[str]:
    name, rep, const = layout.name.title().replace("_", ""), layout.repeated, f"_{layout.name}"
    doc = f"{layout.name} (0x{layout.type_code:02X}): {layout.what}."
    lines = ["", "", "@dataclass(frozen=True)", f"class {name}:"]
    lines += textwrap.wrap(doc, 95, initial_indent='    """', subsequent_indent="    ")
    lines[-1] += '"""'
    lines.append("")
    for f in layout.host_fields:
        lines += _comment(f.what, "    ")
        lines.append(f"    {f.name}: {_py_type(f, repeated=f is rep)}")
    args, at = [], 0
    for f in layout.fields:
        if f.name == layout.count_field:
            pass
        elif f.count > 4:
            args.append(f"v[{at}:{at + f.count}]")
        elif f.count > 1:
            args.append("(" + ", ".join(f"v[{at + i}]" for i in range(f.count)) + ")")
        elif f.host:
            args.append(f'{HOST_TYPES[f.host][1]}("{layout.name}", v[{at}])')
        else:
            args.append(f"v[{at}]")
        at += f.count
    lines += ["", "    @classmethod", f"    def unpack(cls, payload: bytes) -> {name}:"]
    if rep:
        count = layout.names.index(layout.count_field)
        lines += [
            '        """struct.error if `payload` is not as long as its count says."""',
            f"        v = {const}.unpack_from(payload)",
            f"        if len(payload) != {layout.size} + {rep.each} * v[{count}]:",
            f'            raise struct.error(f"{layout.name} of {{len(payload)}} bytes")',
            f'        {rep.name} = struct.unpack_from(f"<{{v[{count}]}}{C_TYPES[rep.ctype][0]}", '
            f"payload, {layout.size})",
        ]
        args.append(rep.name)
    else:
        lines += [
            f'        """struct.error if `payload` is not {layout.size} bytes."""',
            f"        v = {const}.unpack(payload)",
        ]
    call = f"        return cls({', '.join(args)})"
    if len(call) > 100:
        call = "        return cls(\n" + "".join(f"            {a},\n" for a in args) + "        )"
    return [*lines, call]


def _py_request(layout: Layout) -> list[str]:
    rep, const = layout.repeated, f"_{layout.name}"
    params = []
    for f in layout.host_fields:
        base = C_TYPES[f.ctype][3]
        params.append(
            f"{f.name}: Sequence[{base}]" if f.count > 1 or f is rep else f"{f.name}: {base}"
        )
    lines = ["", "", f"def pack_{layout.name.lower()}({', '.join(params)}) -> bytes:"]
    doc = f"{layout.name}'s payload (0x{layout.type_code:02X}): {layout.what}; struct.error for a"
    lines += textwrap.wrap(
        f"{doc} value its C type cannot hold.",
        95,
        initial_indent='    """',
        subsequent_indent="    ",
    )
    lines[-1] += '"""'
    values = []
    for f in layout.fields:
        if f.name == layout.count_field:
            values.append(f"len({rep.name})" if rep else f.name)
        else:
            values.append(f"*{f.name}" if f.count > 1 else f.name)
    head = f"{const}.pack({', '.join(values)})"
    if rep:
        code = C_TYPES[rep.ctype][0]
        head += f' + struct.pack(f"<{{len({rep.name})}}{code}", *{rep.name})'
    return [*lines, f"    return {head}"]


def python_module(messages: Sequence[Message], layouts: Sequence[Layout]) -> str:
    """app/firmware/wire_messages.py: the message types (`Msg`), the struct of each layout, a
    frozen dataclass with `unpack` for each reply, a `pack_<msg>` for each request."""
    lines = [
        '"""The payloads of hardware/firmware/PROTOCOL.md\'s fixed layouts on the host',
        "(docs/DESIGN.md §5): a dataclass with `unpack` per reply, `pack_<msg>` per request.",
        "Generated from hardware/firmware/wire.py (`python -m hardware.firmware.wire",
        '--write-python`); do not edit by hand."""',
        "",
        "from __future__ import annotations",
        "",
        "import struct",
        "from collections.abc import Sequence",
        "from dataclasses import dataclass",
        "from enum import IntEnum",
        "",
        "from app.firmware.wire_values import NakReason, RunState, nak_reason, run_state",
        "",
        "",
        "class Msg(IntEnum):",
        '    """PROTOCOL.md\'s message types: the host\'s, then the robot\'s."""',
        "",
        *(f"    {m.name} = 0x{m.type_code:02X}" for m in messages),
        "",
        "",
    ]
    lines += [f'_{layout.name} = struct.Struct("{layout.codec.format}")' for layout in layouts]
    for layout in layouts:
        lines += _py_reply(layout) if layout.sender == "robot" else _py_request(layout)
    return "\n".join(lines) + "\n"
