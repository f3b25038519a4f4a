"""Emit urb_msgs._accel: a CPython extension that runs the generated C codecs for the Python classes.

Layout: the extension's source is `gen/python/urb_msgs/_accel.c`, next to the modules whose classes it
serves (the usual place of a package's own extension, like a `_speedups.c`), with its type stub
`_accel.pyi` and the selector `_codec.py`; all three are generated in the same `urb gen` run as the C
and Python codecs, so `urb gen --check` covers them. The compiled module is a build product
(`make accel`, urb_codegen.build_accel): `_accel.<EXT_SUFFIX>` in the same folder, never committed.
It links gen/c itself, so the bytes on the wire are the C codecs' own, the ones the proofs are about.

Every conversion is written out per message and field from the schema model: Python slot values to
the C struct (`from_py_<Message>`, which declines anything it cannot convert exactly, so that the
pure-Python codec answers), and the decoded C struct back to an instance (`to_py_<Message>`).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from jinja2 import Environment, FileSystemLoader, StrictUndefined

from .emit_c import _ctype, _member, enum_c, file_stem, msg_c
from .emit_py import _user_fields, banner, module_name
from .model import ArrayType, BytesType, EnumDecl, Field, IntType, MessageDecl, Schema

ACCEL_SOURCE = "_accel.c"


def _all(schemas: list[Schema]) -> list[Schema]:
    out: list[Schema] = []
    for s in schemas:
        for dep in [*s.imports, s]:
            if dep not in out:
                out.append(dep)
    return out


def _nested_first(schemas: list[Schema]) -> list[MessageDecl]:
    """Every message, the ones nested in another first (C needs a converter before its use)."""
    done: list[MessageDecl] = []

    def visit(m: MessageDecl) -> None:
        if m in done:
            return
        for f in m.fields:
            t = f.type.element if isinstance(f.type, ArrayType) else f.type
            if isinstance(t, MessageDecl):
                visit(t)
        done.append(m)

    for s in schemas:
        for m in s.messages.values():
            visit(m)
    return done


def _c_str(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def __call__(self, line: str = "", indent: int = 0) -> None:
        self.lines.append(("    " * indent + line) if line else "")


def _int_range(f: Field, t: IntType) -> tuple[int, int]:
    """The values the pure encoder's check_int accepts for this member (its range, else its type's)."""
    if f.range is not None and f.type is t:
        return f.range
    return t.min, t.max


def _from_py(w: _Writer, f: Field, t: object, value: str, lv: str, depth: int, indent: int) -> None:
    """Statements converting Python object `value` into C lvalue `lv`, `return false;` when it
    cannot be converted exactly (the pure codec then decides)."""
    if isinstance(t, IntType) and t.is_bool:
        w(f"if (!urb_get_bool({value}, &flag)) {{ return false; }}", indent)
        w(f"{lv} = flag;", indent)
    elif isinstance(t, IntType):
        lo, hi = _int_range(f, t)
        w(f"if (!urb_get_int({value}, {lo}LL, {hi}LL, &x)) {{ return false; }}", indent)
        w(f"{lv} = ({_ctype(t)})x;", indent)
    elif isinstance(t, EnumDecl):
        values = [m.value for m in t.members]
        w(f"if (!urb_get_enum({value}, &enum_{t.name}, {min(values)}LL, {max(values)}LL, &x)) {{ return false; }}",
          indent)
        w(f"{lv} = ({_ctype(t.base)})x;", indent)
    elif isinstance(t, MessageDecl):
        w(f"if ({value} == NULL || (PyObject *)Py_TYPE({value}) != (PyObject *)info_{t.name}.cls || "
          f"!from_py_{t.name}({value}, &{lv})) {{ return false; }}", indent)
    elif isinstance(t, ArrayType):
        items, i = f"items{depth}", f"i{depth}"
        w("{", indent)
        w(f"PyObject *const *{items} = urb_get_items({value}, {t.count});", indent + 1)
        w(f"if ({items} == NULL) {{ return false; }}", indent + 1)
        w(f"for (Py_ssize_t {i} = 0; {i} < {t.count}; {i}++) {{", indent + 1)
        _from_py(w, f, t.element, f"{items}[{i}]", f"{lv}[{i}]", depth + 1, indent + 2)
        w("}", indent + 1)
        w("}", indent)
    else:
        raise AssertionError(t)


def _to_py(w: _Writer, f: Field, t: object, value: str, out: str, depth: int, indent: int) -> None:
    """Statements setting `out` to a new reference for C value `value` (NULL on an error)."""
    if isinstance(t, IntType) and t.is_bool:
        w(f"{out} = urb_bool({value});", indent)
    elif isinstance(t, IntType):
        w(f"{out} = PyLong_FromLongLong((long long){value});", indent)
    elif isinstance(t, EnumDecl):
        w(f"{out} = urb_enum_member(&enum_{t.name}, (long long){value});", indent)
    elif isinstance(t, MessageDecl):
        w(f"{out} = to_py_{t.name}(&{value}, NULL);", indent)
    elif isinstance(t, ArrayType):
        i, item = f"i{depth}", f"item{depth}"
        w(f"{out} = PyList_New({t.count});", indent)
        w(f"for (Py_ssize_t {i} = 0; {out} != NULL && {i} < {t.count}; {i}++) {{", indent)
        w(f"PyObject *{item};", indent + 1)
        _to_py(w, f, t.element, f"{value}[{i}]", item, depth + 1, indent + 1)
        w(f"if ({item} == NULL) {{ Py_CLEAR({out}); break; }}", indent + 1)
        w(f"PyList_SET_ITEM({out}, {i}, {item});", indent + 1)
        w("}", indent)
    else:
        raise AssertionError(t)


def _payload_len_member(m: MessageDecl, f: Field) -> str:
    assert isinstance(f.type, BytesType)
    if f.type.count_field is not None:
        counter = next(c for c in m.fields if c.name == f.type.count_field)
        return _member(counter)
    return _member(f) + "_len"


def _message(w: _Writer, m: MessageDecl) -> None:
    n = m.name
    ctype = msg_c(m) + "_t"
    user = _user_fields(m)
    implicit = [f for f in user if f.implicit]
    w(f"/* ----- {n} " + "-" * max(3, 88 - len(n)) + " */")
    w()
    w(f"static const char *const fields_{n}[] = {{{', '.join(_c_str(f.name) for f in user)}{', ' if user else ''}NULL}};")
    size = max(1, len(user))
    w(f"static Py_ssize_t offsets_{n}[{size}];")
    w(f"static PyObject *names_{n}[{size}];")
    w(f"static PyObject *defaults_{n}[{size}];")
    w(f"static PyObject *factories_{n}[{size}];")
    w(f"static PyObject *construct_{n}(PyObject *cls, PyObject *const *args, size_t nargsf, PyObject *kwnames);")
    w(f"static PyObject *encode_{n}(PyObject *self, PyObject *unused);")
    w(f"static PyObject *decode_{n}(PyObject *cls, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames);")
    w(f"static urb_msg_info_t info_{n} = {{")
    w(f".name = {_c_str(n)},", 1)
    w(f".fields = fields_{n},", 1)
    w(f".count = {len(user)},", 1)
    w(f".offsets = offsets_{n},", 1)
    w(f".names = names_{n},", 1)
    w(f".defaults = defaults_{n},", 1)
    w(f".factories = factories_{n},", 1)
    w(f".construct = construct_{n},", 1)
    w(f".encode_def = {{\"encode\", (PyCFunction)encode_{n}, METH_NOARGS, "
      f"\"The frame for this message; EncodeError on a bad value (generated C codec, urb_msgs._accel).\"}},", 1)
    w(f".decode_def = {{\"decode\", (PyCFunction)(void (*)(void))decode_{n}, METH_FASTCALL | METH_KEYWORDS, "
      f"\"Parse one frame; a DecodeError subclass or ArgumentError as the pure codec (urb_msgs._accel).\"}},", 1)
    w("};")
    w()
    w(f"static PyObject *construct_{n}(PyObject *cls, PyObject *const *args, size_t nargsf, PyObject *kwnames)")
    w("{")
    w("(void)cls;", 1)
    w(f"return urb_construct(&info_{n}, args, nargsf, kwnames);", 1)
    w("}")
    w()
    # Python -> C
    w(f"static bool from_py_{n}(PyObject *obj, {ctype} *m)")
    w("{")
    w("long long x;", 1)
    w("bool flag;", 1)
    w("(void)x;", 1)
    w("(void)flag;", 1)
    for k, f in enumerate(user):
        value = f"urb_slot(obj, offsets_{n}[{k}])"
        t = f.type
        if isinstance(t, BytesType):
            w("{", 1)
            w("size_t len;", 2)
            w(f"if (!urb_get_bytes({value}, {t.max_len}u, m->{_member(f)}, &len)) {{ return false; }}", 2)
            w(f"m->{_payload_len_member(m, f)} = (uint8_t)len;", 2)
            w("}", 1)
        else:
            _from_py(w, f, t, value, f"m->{_member(f)}", 0, 1)
    w("return true;", 1)
    w("}")
    w()
    # C -> Python
    w(f"/* A new instance holding *m; `given`: the caller's objects for the implicit members (or NULL). */")
    w(f"static PyObject *to_py_{n}(const {ctype} *m, PyObject *const *given)")
    w("{")
    w("(void)m;", 1)
    w("(void)given;", 1)
    w(f"PyObject *obj = urb_new(&info_{n});", 1)
    w("if (obj == NULL) {", 1)
    w("return NULL;", 2)
    w("}", 1)
    for k, f in enumerate(user):
        w("{", 1)
        w("PyObject *v;", 2)
        t = f.type
        if f.implicit:
            j = implicit.index(f)
            w(f"if (given != NULL) {{ v = given[{j}]; Py_INCREF(v); }} else {{", 2)
            _to_py(w, f, t, f"m->{_member(f)}", "v", 0, 3)
            w("}", 2)
        elif isinstance(t, BytesType):
            w(f"v = PyBytes_FromStringAndSize((const char *)m->{_member(f)}, (Py_ssize_t)m->{_payload_len_member(m, f)});",
              2)
        else:
            _to_py(w, f, t, f"m->{_member(f)}", "v", 0, 2)
        w("if (v == NULL) {", 2)
        w("Py_DECREF(obj);", 3)
        w("return NULL;", 3)
        w("}", 2)
        w(f"urb_slot_init(obj, offsets_{n}[{k}], v);", 2)
        w("}", 1)
    w("return obj;", 1)
    w("}")
    w()
    # encode
    w(f"static PyObject *encode_{n}(PyObject *self, PyObject *unused)")
    w("{")
    w("(void)unused;", 1)
    w(f"{ctype} m;", 1)
    w(f"if (Py_TYPE(self) != info_{n}.cls || !from_py_{n}(self, &m)) {{", 1)
    w(f"return urb_pure_encode(&info_{n}, self);", 2)
    w("}", 1)
    w(f"uint8_t buf[{msg_c(m).upper()}_MAX_SIZE + 1u];", 1)
    w(f"int32_t const r = {msg_c(m)}_encode(&m, buf, sizeof buf);", 1)
    w("if (r < 0) {", 1)
    w(f"return urb_refused_encode(&info_{n}, self, r);", 2)
    w("}", 1)
    w("return PyBytes_FromStringAndSize((const char *)buf, (Py_ssize_t)r);", 1)
    w("}")
    w()
    # decode
    w(f"static PyObject *decode_{n}(PyObject *cls, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames)")
    w("{")
    w(f"{ctype} m;", 1)
    w("const uint8_t *buf;", 1)
    w("size_t len;", 1)
    if implicit:
        names = ", ".join(_c_str(f.name) for f in implicit)
        w(f"static const char *const implicit[] = {{{names}}};", 1)
        w(f"PyObject *given[{len(implicit)}];", 1)
        w(f"if (!urb_implicit_args(args, nargs, kwnames, implicit, {len(implicit)}, given) || "
          "!urb_get_frame(args[0], &buf, &len)) {", 1)
        w(f"return urb_pure_decode(&info_{n}, cls, args, nargs, kwnames);", 2)
        w("}", 1)
        for j, f in enumerate(implicit):
            inner = _Writer()
            _from_py(inner, f, f.type, f"given[{j}]", f"m.{_member(f)}", 0, 0)
            w("{", 1)
            w("long long x;", 2)
            w("bool flag;", 2)
            w("(void)x;", 2)
            w("(void)flag;", 2)
            for line in inner.lines:
                w(line.replace("return false;", f"return urb_pure_decode(&info_{n}, cls, args, nargs, kwnames);"), 2)
            w("}", 1)
    else:
        w("if (nargs != 1 || kwnames != NULL || !urb_get_frame(args[0], &buf, &len)) {", 1)
        w(f"return urb_pure_decode(&info_{n}, cls, args, nargs, kwnames);", 2)
        w("}", 1)
    w(f"int32_t const r = {msg_c(m)}_decode(&m, buf, len);", 1)
    w("if (r < 0) {", 1)
    w(f"return urb_refused_decode(&info_{n}, cls, args, nargs, kwnames, r);", 2)
    w("}", 1)
    w(f"return to_py_{n}(&m, {'given' if implicit else 'NULL'});", 1)
    w("}")
    w()


def _enum(w: _Writer, e: EnumDecl) -> None:
    n = e.name
    w(f"static const char *const members_{n}[] = {{{', '.join(_c_str(m.name) for m in e.members)}}};")
    w(f"static const int64_t values_{n}[] = {{{', '.join(f'{m.value}LL' for m in e.members)}}};")
    w(f"static PyObject *objects_{n}[{len(e.members)}];")
    w(f"static urb_enum_info_t enum_{n} = {{{_c_str(n)}, members_{n}, values_{n}, {len(e.members)}, NULL, objects_{n}}};")
    w()


def fingerprint(c_texts: dict[str, str], accel_body: str) -> str:
    """What the compiled module must match: the C sources it links and its own generated code."""
    h = hashlib.sha256()
    for name in sorted(c_texts):
        h.update(name.encode() + b"\0" + c_texts[name].encode() + b"\0")
    h.update(accel_body.encode())
    return h.hexdigest()[:16]


def emit_pyext(schemas: list[Schema], out_dir: Path, c_dir: Path) -> list[Path]:
    """Write _accel.c, _accel.pyi and _codec.py into the Python package folder; return their paths."""
    everything = _all(schemas)
    w = _Writer()
    enums = [e for s in everything for e in s.enums.values()]
    for e in enums:
        _enum(w, e)
    messages = _nested_first(everything)
    for m in messages:
        _message(w, m)
    # C has no empty arrays: a schema without messages or enums gets a NULL entry that the count leaves out
    w(f"static urb_msg_info_t *const urb_messages[] = {{{', '.join(f'&info_{m.name}' for m in messages) or 'NULL'}}};")
    w(f"static const size_t urb_message_count = {len(messages)}u;")
    w(f"static urb_enum_info_t *const urb_enums[] = {{{', '.join(f'&enum_{e.name}' for e in enums) or 'NULL'}}};")
    w(f"static const size_t urb_enum_count = {len(enums)}u;")
    body = "\n".join(w.lines)
    max_fields = max([1, *(len(_user_fields(m)) for m in messages)])
    c_texts = {p.name: p.read_text(encoding="utf-8") for p in sorted(c_dir.glob("*.[ch]"))}
    fp = fingerprint(c_texts, body)
    env = Environment(loader=FileSystemLoader(str(Path(__file__).parent / "templates")), undefined=StrictUndefined,
                      keep_trailing_newline=True, autoescape=False)
    sources = ", ".join(f"{s.path.name} (schema {s.name}, source fingerprint {s.source_hash})" for s in everything)
    accel = env.get_template("py_accel_c.j2").render(
        source=sources, headers=[file_stem(s) + ".h" for s in everything], fingerprint=fp, body=body,
        max_fields=max_fields)
    codec = env.get_template("py_codec.py.j2").render(banner=banner(None), fingerprint=fp,
                                                      modules=[module_name(s) for s in everything])
    stub = env.get_template("py_accel_pyi.j2").render(banner=banner(None))
    written = []
    for name, text in ((ACCEL_SOURCE, accel), ("_codec.py", codec), ("_accel.pyi", stub)):
        path = out_dir / name
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


__all__ = ["ACCEL_SOURCE", "emit_pyext", "fingerprint", "enum_c"]
