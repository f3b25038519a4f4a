#!/usr/bin/env python3
"""Generates the C tables of the Cortex-M0 test program (tests/qemu/qemu_main.c) into build/qemu/gen/.

qt_vectors.c  every reference vector of tests/vectors/*.json as C data: the frame, the expected
              struct as a designated initializer (built from the vector's `fields` and `implicit`
              through the schema model, not through the C codecs), the error a decoder must
              return, plus per-message encode/decode/implicit/compare functions.
qt_node.h     the node smoke test's scenario and the bytes the node must send and accept, built
              with the Python codecs (urb_msgs): Identification of the motor driver read from
              outbox 0, DownlinkWrite frames for inboxes 1 and 2, MotorFeedback read from outbox 1.

Nothing here is committed: mk/qemu.mk runs it at build time.
Usage: gen_tables.py --out build/qemu/gen
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

try:
    import urb_msgs
    from urb_msgs.sensorhex import MotorCommand, MotorConfig, MotorFeedback, MotorMode
    from urb_msgs.urb_core import DownlinkReadResponse, DownlinkWrite, Identification, MailboxSelect
    from urb_codegen.emit_c import _member as member  # the C member of a field (reserved words get a "_")
    from urb_codegen.emit_c import msg_c, snake
    from urb_codegen.generate import load_bundled
    from urb_codegen.model import ArrayType, BytesType, CheckType, EnumDecl, Field, IntType, MessageDecl
except ImportError as exc:  # a bare checkout: `make setup` installs the packages
    sys.exit(f"gen_tables.py: {exc}; run `make setup` (tools/setup.sh) first")

ERRORS = {"short": "URB_ERR_SHORT", "long": "URB_ERR_LONG", "checksum": "URB_ERR_CHECKSUM", "range": "URB_ERR_RANGE",
          "argument": "URB_ERR_ARGUMENT"}

# ----- the node smoke test scenario (qemu_main.c runs it; the bytes are computed here) ------------
NODE_ADDRESS = 0x40
NODE_INDEX = 3
MOTOR_FW = (1, 0, 0)  # MOTOR_FW_MAJOR/MINOR/PATCH in firmware/apps/sensorhex/sensorhex_motor.c
ENCODER, CURRENT_MA, VOLTAGE_MV, CASE_TEMP = 1234, -1500, 6000, 2500
COMMAND_MV = 4500  # within the 6 V limit MotorConfig sets: the drive follows it
BAD_COMMAND_MV = -9000  # sent with a corrupted check: must be NACKed and never applied
VOLTAGE_LIMIT_MV = 6000


def members(m: MessageDecl) -> list[Field]:
    """Fields that are struct members: no padding, fixed values or checks."""
    return [f for f in m.fields if not f.is_padding and f.fixed is None and not isinstance(f.type, CheckType)]


def c_int(value: int, t: IntType) -> str:
    if t.is_bool:
        return "true" if value else "false"
    if not t.signed:
        return f"{value}u"
    return f"({value + 1} - 1)" if value == -(1 << 31) else str(value)


def c_bytes(data: bytes) -> str:
    return "{" + ", ".join(f"0x{b:02x}u" for b in data) + "}" if data else "{0u}"


def c_value(t: object, value: Any) -> str:
    if isinstance(t, IntType):
        return c_int(int(value), t)
    if isinstance(t, EnumDecl):
        return c_int(int(value), t.base)
    if isinstance(t, MessageDecl):
        return c_struct(t, value)
    assert isinstance(t, ArrayType), t
    assert len(value) == t.count, (t, value)
    return "{" + ", ".join(c_value(t.element, v) for v in value) + "}"


def c_struct(m: MessageDecl, values: dict[str, Any]) -> str:
    """A designated initializer for m's C struct from plain values (as in the vector files)."""
    parts: list[str] = []
    counts: dict[str, int] = {}
    for f in members(m):
        if isinstance(f.type, BytesType):
            data = bytes.fromhex(values[f.name])
            parts.append(f".{member(f)} = {c_bytes(data)}")
            if f.type.count_field is None:
                parts.append(f".{member(f)}_len = {len(data)}u")
            else:
                counts[f.type.count_field] = len(data)
    for f in members(m):
        if isinstance(f.type, BytesType):
            continue
        if f.name in values:
            value = values[f.name]
        elif f.name in counts:  # a count field: the vectors give the payload, not its length
            value = counts[f.name]
        else:
            raise SystemExit(f"gen_tables.py: {m.name}: no value for field {f.name}")
        parts.append(f".{member(f)} = {c_value(f.type, value)}")
    return "{" + ", ".join(parts) + "}"


def c_implicit_only(m: MessageDecl, implicit: dict[str, Any]) -> str:
    """Initializer setting only the implicit members (error vectors: what set_implicit copies)."""
    return "{" + ", ".join(f".{member(f)} = {c_value(f.type, implicit[f.name])}" for f in m.implicit_fields) + "}"


def compare_lines(fields: list[Field], expr: str, path: str) -> list[str]:
    """C statements returning the path of the first member of *got that differs from *want."""
    out: list[str] = []
    counts = {f.type.count_field for f in fields if isinstance(f.type, BytesType)}
    for f in fields:
        if f.is_padding or f.fixed is not None or isinstance(f.type, CheckType) or f.name in counts:
            continue  # a count field is compared with its payload
        g, w, p = f"got->{expr}{member(f)}", f"want->{expr}{member(f)}", path + f.name
        if isinstance(f.type, BytesType):
            counter = next((c for c in fields if c.name == f.type.count_field), None)
            length = member(counter) if counter is not None else member(f) + "_len"
            out.append(f"if (got->{expr}{length} != want->{expr}{length}) {{ return \"{path}{f.type.count_field or f.name + '_len'}\"; }}")
            out.append(f"if (memcmp({g}, {w}, want->{expr}{length}) != 0) {{ return \"{p}\"; }}")
        else:
            out += _compare_value(f.type, f"{expr}{member(f)}", p)
    return out


def _compare_value(t: object, expr: str, path: str) -> list[str]:
    if isinstance(t, (IntType, EnumDecl)):
        return [f"if (got->{expr} != want->{expr}) {{ return \"{path}\"; }}"]
    if isinstance(t, MessageDecl):
        return compare_lines(t.fields, expr + ".", path + ".")
    assert isinstance(t, ArrayType), t
    out: list[str] = []
    for i in range(t.count):
        out += _compare_value(t.element, f"{expr}[{i}]", f"{path}[{i}]")
    return out


def load_vectors() -> list[tuple[str, int, dict[str, Any]]]:
    out = []
    for path in sorted((REPO / "tests" / "vectors").glob("*.json")):
        for i, v in enumerate(json.loads(path.read_text())):
            out.append((path.name, i, v))
    return out


def vectors_c(messages: dict[str, MessageDecl]) -> str:
    vectors = load_vectors()
    used = sorted({v["message"] for _, _, v in vectors}, key=list(messages).index)
    lines = [
        "/* Generated by tests/qemu/gen_tables.py from tests/vectors (every .json) and spec/schema; do not edit. */",
        "#include <stdbool.h>", "#include <stddef.h>", "#include <stdint.h>", "#include <string.h>", "",
        '#include "qt_tables.h"', '#include "urb_runtime.h"',
        # every generated schema header (the vectors cover every schema's messages)
        *(f'#include "{h.name}"' for h in sorted((REPO / "gen" / "c").glob("urb_*.h")) if h.name != "urb_runtime.h"),
        "",
    ]
    for name in used:
        m = messages[name]
        fn, t = msg_c(m), msg_c(m) + "_t"
        lines += [
            f"/* {name} */",
            f"static int32_t enc_{fn}(const void *msg, uint8_t *buf, size_t capacity)",
            f"{{\n    return {fn}_encode(msg, buf, capacity);\n}}",
            f"static int32_t dec_{fn}(void *msg, const uint8_t *buf, size_t length)",
            f"{{\n    return {fn}_decode(msg, buf, length);\n}}",
            f"static const char *cmp_{fn}(const void *got_v, const void *want_v)",
            "{",
            f"    const {t} *got = got_v;",
            f"    const {t} *want = want_v;",
            *("    " + s for s in compare_lines(m.fields, "", "")),
            "    return NULL;",
            "}",
        ]
        if m.implicit_fields:
            lines += [
                f"static void imp_{fn}(void *to_v, const void *from_v)",
                "{",
                f"    {t} *to = to_v;",
                f"    const {t} *from = from_v;",
                *(f"    to->{member(f)} = from->{member(f)};" for f in m.implicit_fields),
                "}",
            ]
        lines += [
            f"static const qt_message_t msg_{fn} = {{\"{name}\", sizeof({t}), {fn.upper()}_MAX_SIZE, enc_{fn}, dec_{fn},",
            f"    {'imp_' + fn if m.implicit_fields else 'NULL'}, cmp_{fn}}};",
            "",
        ]
    lines.append("/* the vectors, in file order */")
    table: list[str] = []
    for k, (file, i, v) in enumerate(vectors):
        m = messages[v["message"]]
        fn, t = msg_c(m), msg_c(m) + "_t"
        frame = bytes.fromhex(v["hex"])
        lines.append(f"static const uint8_t frame_{k}[] = {c_bytes(frame)};")
        if "error" in v:
            fields = "NULL"
            if m.implicit_fields:
                lines.append(f"static const {t} fields_{k} = {c_implicit_only(m, v['implicit'])};")
                fields = f"&fields_{k}"
            error = ERRORS[v["error"]]
        else:
            lines.append(f"static const {t} fields_{k} = {c_struct(m, {**v['fields'], **v.get('implicit', {})})};")
            fields, error = f"&fields_{k}", "0"
        table.append(f"    {{&msg_{fn}, frame_{k}, {len(frame)}u, {fields}, {error}, \"{file} #{i}\"}},")
    lines += ["", "const qt_vector_t qt_vectors[] = {", *table, "};",
              "const size_t qt_vector_count = sizeof qt_vectors / sizeof qt_vectors[0];", ""]
    union = "\n".join(f"    {msg_c(messages[n])}_t m_{snake(n)};" for n in used)
    lines += [
        "/* decode target: large and aligned enough for every message above */",
        f"static union {{\n{union}\n}} scratch;",
        "void *const qt_scratch = &scratch;",
        "const size_t qt_scratch_size = sizeof scratch;",
        "",
    ]
    return "\n".join(lines)


def node_h() -> str:
    motor = urb_msgs.NODES["MotorDriver"]
    ident = Identification(
        class_id=motor.class_id, index=NODE_INDEX, fingerprint=motor.fingerprint,
        fw_major=MOTOR_FW[0], fw_minor=MOTOR_FW[1], fw_patch=MOTOR_FW[2],
        inbox_sizes=motor.sizes("inbox"), outbox_sizes=motor.sizes("outbox"),
        synced=False, fault=False, acq_time=0,
    ).encode()
    config = MotorConfig(mode=MotorMode.VOLTAGE, kp=0, kd=0, target=0, voltage_limit=VOLTAGE_LIMIT_MV).encode()
    feedback = MotorFeedback(encoder=ENCODER, current=CURRENT_MA, voltage=VOLTAGE_MV).encode()

    def write(inbox: int, data: bytes) -> bytes:
        return DownlinkWrite(select=MailboxSelect(mailbox=inbox, read=False), data=data).encode()

    def read(outbox: int, data: bytes) -> bytes:
        # what the master clocks in: data, check over (select | data), then the node's 0xFF filler
        return DownlinkReadResponse(select=MailboxSelect(mailbox=outbox, read=True), data=data).encode() + b"\xff"

    bad = bytearray(write(1, MotorCommand(voltage=BAD_COMMAND_MV).encode()))
    bad[-1] ^= 0x01
    arrays = {
        "qt_ident_read": read(0, ident),
        "qt_write_config": write(2, config),
        "qt_write_command": write(1, MotorCommand(voltage=COMMAND_MV).encode()),
        "qt_write_bad_command": bytes(bad),
        "qt_feedback_read": read(1, feedback),
    }
    lines = [
        "/* Generated by tests/qemu/gen_tables.py with the Python codecs (urb_msgs); do not edit. */",
        "#ifndef QT_NODE_H", "#define QT_NODE_H", "", "#include <stdint.h>", "",
        f"#define QT_NODE_ADDRESS 0x{NODE_ADDRESS:02x}u",
        f"#define QT_NODE_INDEX {NODE_INDEX}u",
        f"#define QT_MOTOR_ENCODER {ENCODER}u",
        f"#define QT_MOTOR_CURRENT_MA ({CURRENT_MA})",
        f"#define QT_MOTOR_VOLTAGE_MV ({VOLTAGE_MV})",
        f"#define QT_MOTOR_CASE_TEMP ({CASE_TEMP})",
        f"#define QT_COMMAND_MV ({COMMAND_MV})",
        f"#define QT_BAD_COMMAND_MV ({BAD_COMMAND_MV})",
        f"#define QT_VOLTAGE_LIMIT_MV ({VOLTAGE_LIMIT_MV})",
        "",
    ]
    for name, data in arrays.items():
        lines.append(f"static const uint8_t {name}[{len(data)}] = {c_bytes(data)};")
    lines += ["", "#endif /* QT_NODE_H */", ""]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    messages = {m.name: m for s in load_bundled() for m in s.messages.values()}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "qt_vectors.c").write_text(vectors_c(messages))
    (args.out / "qt_node.h").write_text(node_h())


if __name__ == "__main__":
    main()
