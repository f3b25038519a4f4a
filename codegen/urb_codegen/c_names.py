"""C names and C types of schema items, shared by the C emitter and the proof generators.

One source of truth for how a message, enum, member or integer type is spelled in generated C:
`emit_c`, `c_fields` and `proofs/bmc/generate.py` all import these.
"""

from __future__ import annotations

import re

from .model import EnumDecl, Field, IntType, MessageDecl, Schema

# C99 keywords and the names <stdbool.h>/<stdint.h> take; a field named like one gets a trailing "_".
_C_RESERVED = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if inline int long "
    "register restrict return short signed sizeof static struct switch typedef union unsigned void volatile "
    "while _Bool _Complex _Imaginary bool true false NULL".split()
)


def snake(name: str) -> str:
    """`UplinkReadRequest` -> `uplink_read_request`; `USBHeader` -> `usb_header`."""
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])", "_", name).lower()


def _member(f: Field) -> str:
    return _c_name(f.name)


def _c_name(name: str) -> str:
    """The C struct member of a field named `name`: a C keyword gets a trailing `_`."""
    return name + "_" if name in _C_RESERVED else name


def _comment(text: str) -> str:
    """Text safe inside a C block comment."""
    return text.replace("*/", "* /").replace("/*", "/ *")


def _ctype(t: IntType) -> str:
    if t.is_bool:
        return "bool"
    size = 8 if t.bits <= 8 else 16 if t.bits <= 16 else 32
    return f"{'int' if t.signed else 'uint'}{size}_t"


def _ctype_limits(t: IntType) -> tuple[int, int]:
    size = 8 if t.bits <= 8 else 16 if t.bits <= 16 else 32
    return (-(1 << (size - 1)), (1 << (size - 1)) - 1) if t.signed else (0, (1 << size) - 1)


def _literal(value: int, signed: bool) -> str:
    if not signed:
        return f"{value}u"
    return f"({value + 1} - 1)" if value == -(1 << 31) else str(value)


def msg_c(m: MessageDecl) -> str:
    """C name stem of a message: `urb_uplink_read_request`."""
    return "urb_" + snake(m.name)


def enum_c(e: EnumDecl) -> str:
    return "urb_" + snake(e.name)


def file_stem(s: Schema) -> str:
    return s.name if s.name.startswith("urb_") else "urb_" + s.name
