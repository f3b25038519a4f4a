"""`urb gen`, `urb schema check`, `urb schema show`: the schema compiler's commands."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from urb_codegen.errors import SchemaError, SchemaErrors
from urb_codegen.generate import C_DIR, PY_DIR, SCHEMA_DIR, check_files, check_fresh, generate, schema_files
from urb_codegen.model import ArrayType, BytesType, CheckType, EnumDecl, IntType, MessageDecl, Schema
from urb_codegen.parser import load

_Sub = "argparse._SubParsersAction[argparse.ArgumentParser]"


def register(sub: Any) -> None:
    """Add the schema commands to the `urb` parser."""
    fmt = argparse.RawDescriptionHelpFormatter
    gen = sub.add_parser(
        "gen", help="generate the C and Python codecs from the schemas", formatter_class=fmt,
        description="Generate the C codecs (gen/c/) and Python codecs (gen/python/urb_msgs/) from every\n"
        "schema in the schema folder. With --check, generate into a temporary folder and fail\n"
        "(exit 1) when the committed files differ: the staleness check CI runs.\n"
        "\n"
        "Exit status: 0 the codecs were written (with --check: the committed ones are up to date);\n"
        "1 a schema error, no *.urbs file in the schema folder, or (with --check) stale files; 2 a\n"
        "usage error (an unknown option).",
    )
    gen.add_argument("--schemas", type=Path, default=SCHEMA_DIR, metavar="DIR", help="schema folder (default: spec/schema)")
    gen.add_argument("--c-out", type=Path, default=C_DIR, metavar="DIR", help="C output folder (default: gen/c)")
    gen.add_argument("--py-out", type=Path, default=PY_DIR, metavar="DIR", help="Python output folder (default: gen/python/urb_msgs)")
    gen.add_argument("--check", action="store_true", help="do not write; exit 1 if the committed output is stale")
    gen.set_defaults(run=run_gen)

    schema = sub.add_parser("schema", help="check schema files or show wire layouts", formatter_class=fmt,
                            description="Check schema files or show their wire layouts.",
                            epilog="Exit status: that of the SUBCOMMAND; 2 (a usage error) without one.")
    ssub = schema.add_subparsers(title="subcommands", dest="schema_command", metavar="SUBCOMMAND")
    check = ssub.add_parser(
        "check", help="check schema files", formatter_class=fmt,
        description="Parse and check schema files, and generate their code into a scratch folder (the\n"
        "checks only the C and Python emitters can make, such as a name that clashes with the\n"
        "runtime's). Every error is printed as file:line:column with the source line, a caret and a\n"
        "one-line hint; a conflict between two declarations also shows the other one as\n"
        "file:line:column: note:.\n"
        "\n"
        "Each FILE is checked with its siblings, the *.urbs files of its folder: `urb gen --schemas\n"
        "FOLDER` generates them together, into one C namespace and one Python package. Shown: the\n"
        "errors in FILE and in the files it imports, and every conflict between FILE and a sibling\n"
        "(the same name declared twice, one node class for two nodes, two items with one C name),\n"
        "located at FILE's declaration. A sibling's errors that do not involve FILE are not shown\n"
        "and do not fail the check: a note names the sibling and counts them, and says when some of\n"
        "its declarations could not be compared with FILE's (`urb schema check FOLDER/*.urbs` shows\n"
        "every error of a folder). FILEs from different folders are checked each with its own folder,\n"
        "never against each other. A FOLDER given as FILE stands for its *.urbs files. Without\n"
        "FILE, every bundled schema (spec/schema) is checked.\n"
        "\n"
        "Exit status: 0 when every FILE is valid with its siblings (a folder whose files are each\n"
        "valid, `urb gen` accepts); 1 otherwise, or when a FILE does not exist or a folder holds no\n"
        "*.urbs file; 2 a usage error (an unknown option).",
    )
    check.add_argument("files", nargs="*", type=Path, metavar="FILE",
                       help="schema files, each checked with its folder's, or folders of them "
                            "(default: every bundled schema)")
    check.set_defaults(run=run_check)
    show = ssub.add_parser(
        "show", help="show message and node layouts", formatter_class=fmt,
        description="Show the wire layout of a message (bit offsets, types, units, fingerprint) and the\n"
        "rules every valid message meets, or the mailboxes of a node. Without NAME, list every message\n"
        "and node.\n"
        "\n"
        "Exit status: 0 shown; 1 no message or node named NAME, or schemas that do not load (their\n"
        "errors are printed); 2 a usage error (an unknown option).",
    )
    show.add_argument("name", nargs="?", metavar="NAME", help="message or node name")
    show.add_argument("--schemas", type=Path, default=SCHEMA_DIR, metavar="DIR", help="schema folder (default: spec/schema)")
    show.set_defaults(run=run_show)
    schema.set_defaults(run=lambda args: schema.error("give a SUBCOMMAND: check or show (`urb schema --help`)"))


def _load(paths: list[Path]) -> list[Schema] | None:
    """Load schemas, printing errors (never a traceback) and returning None on failure."""
    if not paths:
        print("urb: no schema files found; pass files or --schemas DIR with *.urbs files", file=sys.stderr)
        return None
    try:
        return load(paths)
    except SchemaErrors as exc:
        _print_errors(exc.errors)
    except SchemaError as exc:
        print(exc.render(), file=sys.stderr)
    return None


def _print_errors(errors: list[SchemaError]) -> None:
    """Every error rendered (file:line:column, source line, caret, hint), then how many."""
    print(SchemaErrors(errors).render(), file=sys.stderr)
    print(f"\n{len(errors)} error(s)", file=sys.stderr)


def run_gen(args: argparse.Namespace) -> int:
    schemas = _load(schema_files(args.schemas))
    if schemas is None:
        return 1
    if args.check:
        try:
            result = check_fresh(schemas, args.c_out, args.py_out)
        except SchemaError as exc:
            print(exc.render(), file=sys.stderr)
            return 1
        if result.fresh:
            print("urb gen --check: generated files are up to date")
            return 0
        for label, paths in (("changed", result.changed), ("missing", result.missing), ("not generated", result.extra)):
            for p in paths:
                print(f"  {label}: {p}", file=sys.stderr)
        print("urb gen --check: generated files are stale; run `urb gen` (or `make gen`) and commit the result",
              file=sys.stderr)
        return 1
    try:
        written = generate(schemas, args.c_out, args.py_out)
    except SchemaError as exc:  # problems only an emitter sees, e.g. two items with the same C name
        print(exc.render(), file=sys.stderr)
        return 1
    print(f"urb gen: wrote {len(written)} files from {len(schemas)} schema(s)")
    return 0


def run_check(args: argparse.Namespace) -> int:
    paths: list[Path] = []
    empty: list[Path] = []
    for given in list(args.files) or [SCHEMA_DIR]:
        if given.is_dir():  # a folder: its *.urbs files, which `urb gen --schemas` takes together
            found = schema_files(given)
            paths += found
            if not found:
                empty.append(given)
        else:
            paths.append(given)
    for folder in empty:
        print(f"urb schema check: {folder}: no *.urbs files in this folder; give schema files, or a folder "
              f"that holds them", file=sys.stderr)
    missing = [p for p in paths if not p.exists()]
    for p in missing:
        print(f"urb schema check: {p}: no such file; give schema files (*.urbs) or a folder that holds them",
              file=sys.stderr)
    if empty or missing:
        return 1
    checks = check_files(paths)
    errors = [e for c in checks for e in c.errors]
    if errors:
        _print_errors(errors)
    for c in checks:
        for s in c.schemas:
            print(f"{s.path}: ok ({len(s.messages)} messages, {len(s.enums)} enums, {len(s.nodes)} nodes)")
        files = " and ".join(str(f) for f in c.files)
        for sibling in sorted(set(c.elsewhere) | c.uncompared):
            count = c.elsewhere.get(sibling, 0)
            says = (f"has {count} error{'s' if count > 1 else ''} of its own (not shown: `urb schema check {sibling}` "
                    f"shows {'them' if count > 1 else 'it'})" if count else "imports a sibling with errors")
            also = (f"; some of its declarations could not be compared with {files}'s: check again once it is fixed"
                    if sibling in c.uncompared else "")
            print(f"urb schema check: note: {sibling}, generated together with {files} by `urb gen`, {says}{also}",
                  file=sys.stderr)
    return 1 if errors else 0


def _type_name(t: object) -> str:
    if isinstance(t, IntType):
        return t.name
    if isinstance(t, EnumDecl):
        return f"{t.name} ({t.base.name})"
    if isinstance(t, MessageDecl):
        return t.name
    if isinstance(t, ArrayType):
        return f"{_type_name(t.element)}[{t.count}]"
    if isinstance(t, BytesType):
        return f"bytes[{t.count_field + ' ' if t.count_field else ''}<= {t.max_len}]"
    if isinstance(t, CheckType):
        return f"{t.checksum.name} over {t.first}..{t.last}"
    return str(t)


def run_show(args: argparse.Namespace) -> int:
    schemas = _load(schema_files(args.schemas))
    if schemas is None:
        return 1
    console = Console(highlight=False)
    messages = {m.name: m for s in schemas for sch in [*s.imports, s] for m in sch.messages.values()}
    nodes = {n.name: n for s in schemas for sch in [*s.imports, s] for n in sch.nodes.values()}
    if args.name is None:
        table = Table(title="Messages")
        for col in ("name", "schema", "bytes", "fingerprint", "rules", "doc"):
            table.add_column(col)
        for m in messages.values():
            size = str(m.min_size) if m.min_size == m.max_size else f"{m.min_size}..{m.max_size}"
            table.add_row(m.name, m.schema, size, f"{m.fingerprint:08x}", str(len(m.rules)) if m.rules else "", m.doc)
        console.print(table)
        ntable = Table(title="Nodes")
        for col in ("name", "class", "fingerprint", "mailboxes", "doc"):
            ntable.add_column(col)
        for n in nodes.values():
            boxes = ", ".join(f"{b.direction[:-3]}{b.number}:{b.message.name}({b.size})" for b in n.mailboxes)
            ntable.add_row(n.name, f"0x{n.class_id:02x}", f"{n.fingerprint:08x}", boxes, n.doc)
        console.print(ntable)
        return 0
    if args.name in messages:
        m = messages[args.name]
        size = f"{m.min_size}" if m.min_size == m.max_size else f"{m.min_size}..{m.max_size}"
        table = Table(title=f"{m.name}: {m.doc}", caption=f"{size} bytes, fingerprint {m.fingerprint:08x}")
        for col in ("bits", "field", "type", "value", "unit", "doc"):
            table.add_column(col)
        for f in m.fields:
            if isinstance(f.type, (BytesType, CheckType)):
                bits = "payload" if isinstance(f.type, BytesType) else "check"
            else:
                bits = f"{f.bit_offset}..{f.bit_offset + f.bit_width - 1}" + (" (implicit)" if f.implicit else "")
            value = f"= {f.fixed_name or f.fixed}" if f.fixed is not None else (f"{f.range[0]}..{f.range[1]}" if f.range else "")
            unit = (f.unit or "") + (f" x{f.scale:g}" if f.scale is not None else "") + (f" {f.offset:+g}" if f.offset else "")
            table.add_row(bits, f.name, _type_name(f.type), value, unit, f.doc)
        console.print(table)
        if m.rules:
            rules = Table(title=f"{m.name}: rules a valid message meets (a decoder refuses any other)")
            for col in ("rule", "checked", "doc"):
                rules.add_column(col)
            for r in m.rules:
                # a caller's rule is about the decoder's arguments (implicit members), checked before the frame
                rules.add_row(f"require {r.text}", "on the arguments" if r.caller_only else "on the frame", r.doc)
            console.print(rules)
        return 0
    if args.name in nodes:
        n = nodes[args.name]
        table = Table(title=f"{n.name} (class 0x{n.class_id:02x}): {n.doc}", caption=f"layout fingerprint {n.fingerprint:08x}")
        for col in ("mailbox", "message", "bytes", "rate", "doc"):
            table.add_column(col)
        for b in n.mailboxes:
            rate = f"{b.rate_hz:g} Hz" if b.rate_hz else ""
            table.add_row(f"{b.direction} {b.number}", b.message.name, str(b.size), rate, b.doc)
        console.print(table)
        return 0
    print(f"urb schema show: no message or node named {args.name!r}; run `urb schema show` for the list", file=sys.stderr)
    return 1
