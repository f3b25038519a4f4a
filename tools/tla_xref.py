#!/usr/bin/env python3
"""Cross-reference the TLA+ actions and the production C that implements them.

The C is the firmware's and the native host library's (host/c: the host's actions of Bridge.tla,
Discovery.tla and UsbUplink.tla, BY_HOST). Every mention of a TLA+ module in a comment of either is
parsed, and each must be one of:

* an implementation citation `Module.tla: Action` (colon): this code performs the action. It must
  name an action of the module (an operator a next-state relation takes, not any definition), sit
  in a production `.c` file of the part of the firmware that implements the module (MODULE_HOME)
  inside a function or in the comment right above one, and be the only production file citing
  that action (the host's actions, BY_HOST, live in host/c, the others in MODULE_HOME);
* a reference `Module.tla Name` or `Name of Module.tla`: this code calls, mirrors or relies on a
  definition (an action, invariant, operator, constant or variable), which must exist;
* a mention of the module itself (`spec/tla/Bridge.tla, UsbUplink.tla and ...`), which must exist.

`Module.tla:` followed by anything but a name is an error (a citation that cannot be read). Test
doubles (TEST_DOUBLES: the hosted and simulated HALs and the hosted bridge program) are checked the
same way but never count as an implementation; every C file under firmware/ must be classified as
production or test double. Every action of every specification in spec/tla must then have exactly
one production implementation, unless it is the application's (BY_APPLICATION) or the
environment's (BY_ENVIRONMENT). `--table` prints the action -> implementation table that
spec/tla/README.md carries (file and functions).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from urb_report import c_source

REPO = Path(__file__).resolve().parents[1]
TLA_DIRS = [REPO / "spec" / "tla", REPO / "sim" / "tla"]
SPEC_DIR = REPO / "spec" / "tla"
FIRMWARE = "firmware"
HOST_LIBRARY = "host/c"

# Every C file under firmware/ is one or the other; the test doubles are matched first.
TEST_DOUBLES = ("firmware/hal/hosted/", "firmware/hal/sim/", "firmware/bridge/hosted_main.c")
PRODUCTION = ("firmware/node/", "firmware/bridge/", "firmware/include/", "firmware/apps/",
              "firmware/hal/cortex-m0plus/", "firmware/downlink/", "host/c/core/", "host/c/port/", "host/c/include/")

# The production folder whose code each model describes: an implementation citation elsewhere (the
# bridge's I2C master citing the node's mailbox) is an error.
MODULE_HOME = {
    "MailboxInbox": "firmware/node/",
    "MailboxOutbox": "firmware/node/",
    "Bridge": "firmware/bridge/",
    "UsbUplink": "firmware/bridge/",
    "Discovery": "firmware/bridge/",
    "CanTransfer": "firmware/downlink/can/",
    "Rs485Poll": "firmware/downlink/rs485/",
}

# Actions done by application code through the locked buffer pointer, not by the library.
BY_APPLICATION = {
    "MailboxOutbox": {"AppWriteByte"},
    "MailboxInbox": {"AppReadByte"},
}
BY_ENVIRONMENT = {
    "Discovery": {"NodeVanish": "the bus: a node leaves", "NodeAppear": "the bus: a node joins"},
    "CanTransfer": {"Lose": "the bus: a receiver's controller overruns",
                    "Duplicate": "the bus: an error in the end of frame's last bit",
                    "ErrorFrame": "the CAN controller: error frames, error counter, bus-off",
                    "Recover": "the CAN controller: bus-off recovery"},
    "Rs485Poll": {"BabbleStart": "the line: a babbling node", "BabbleStop": "the line: a babbling node"},
}
# Actions the host does: the native host library implements each, once (HostLinkLost: the host's
# reaction to a failed link or a silent bridge; Submit and Callback: the library's side of the
# application's request and of its completion).
BY_HOST = {
    "Bridge": {"HostTimeout", "HostExpire", "HostLinkLost", "HostReopen", "HostRestart"},
    "Discovery": {"HostBuildTable"},
    "UsbUplink": {"Submit", "Callback"},
}
HOST_HOME = "host/c/"

DEFINITION = re.compile(r"^([A-Z]\w*)\s*(\((?:[^()]|\([^()]*\))*\))?\s*==", re.MULTILINE)  # parameters may be operators: R(_, _)
DECLARED = re.compile(r"^(?:CONSTANTS?|VARIABLES?)\b(.*?)(?=^\S|\Z)", re.MULTILINE | re.DOTALL)
# `SendEnd == SendEndWith(FALSE)`: an action fixed from a parameterised one (whose other arguments
# make the mutants) is the action the next-state relation names.
SPECIALISATION = re.compile(r"([A-Z]\w*)\s*\([^()]*\)")
NEXT_STATE = re.compile(r"\[\]\[\s*([A-Z]\w*)\s*\]_")  # [][Next]_vars
# A module mention, with an optional path (spec/tla/Bridge.tla), and what follows it.
MENTION = re.compile(r"(?<![\w.])((?:[\w.-]+/)*)([A-Za-z]\w*)\.tla\b")
AFTER_COLON = re.compile(r":[ \t]*([A-Z]\w*)\b")
AFTER_SPACE = re.compile(r"[ \t]+([A-Z]\w*)\b")
NAME_OF = re.compile(r"\b([A-Z]\w*) of $")
CONTINUATION = re.compile(r"\n[ \t]*(?:\*(?!/)[ \t]?|//[ \t]?)?")


@dataclass(frozen=True)
class Citation:
    """One parsed mention: `kind` is "implements", "refers" or "module"; `name` is "" for a module."""

    kind: str
    module: str
    name: str
    path: str  # relative to the repository
    line: int
    function: str  # the function an implementation citation belongs to ("" when none)


# =============================================================================== TLA+ side


def module_file(module: str, prefix: str = "") -> Path | None:
    """The .tla file of a module: at the given path, else in spec/tla or sim/tla."""
    if prefix:
        p = REPO / prefix / f"{module}.tla"
        return p if p.is_file() else None
    return next((d / f"{module}.tla" for d in TLA_DIRS if (d / f"{module}.tla").is_file()), None)


def _uncommented(tla: str) -> str:
    return re.sub(r"\(\*.*?\*\)|\\\*[^\n]*", "", tla, flags=re.DOTALL)


def definitions(module: str) -> dict[str, str]:
    """Operator name -> body text for one module."""
    path = module_file(module)
    if path is None:
        raise FileNotFoundError(f"no module {module} in spec/tla or sim/tla")
    text = path.read_text()
    matches = list(DEFINITION.finditer(text))
    out: dict[str, str] = {}
    for m, nxt in zip(matches, [*matches[1:], None]):
        out[m.group(1)] = text[m.end(): nxt.start() if nxt else len(text)]
    return out


def names(module: str) -> set[str]:
    """Everything a reference may name: operators, constants and variables of the module."""
    path = module_file(module)
    assert path is not None
    declared = {n for block in DECLARED.findall(_uncommented(path.read_text()))
                for n in re.findall(r"\b([A-Za-z]\w*)\b", block)}
    return set(definitions(module)) | declared


def actions(module: str) -> list[str]:
    """The actions of every next-state relation a specification of the module uses (`[][Next]_vars`,
    and Bridge.tla's ReconnectNext, ResetNext and RestartNext): operators they name that change
    state (have primes), found by expanding the ones that only combine others (IsrNext, AppNext,
    ...); an operator that only applies a primed one to fixed arguments (Rs485Poll.tla's
    `SendEnd == SendEndWith(FALSE)`) is an action under its own name."""
    defs = definitions(module)
    out: list[str] = []

    def expand(name: str, seen: set[str]) -> None:
        if name in seen:
            return
        seen.add(name)
        body = _uncommented(defs[name])
        special = SPECIALISATION.fullmatch(body.strip())
        if name not in roots and ("'" in body or (special is not None and special.group(1) in defs
                                                   and "'" in _uncommented(defs[special.group(1)]))):
            if name not in out:
                out.append(name)
            return
        for ident in re.findall(r"\b[A-Z]\w*\b", body):
            if ident in defs:
                expand(ident, seen)

    roots = [m.group(1) for body in defs.values() for m in NEXT_STATE.finditer(_uncommented(body))]
    for root in dict.fromkeys(roots):
        expand(root, set())
    return out


def specified_modules() -> list[str]:
    """The models of spec/tla (not their MC* model-checking wrappers)."""
    return sorted(p.stem for p in SPEC_DIR.glob("*.tla") if not p.stem.startswith("MC"))


# =============================================================================== C side


def c_sources() -> dict[str, str]:
    """Relative path -> text of every C file under firmware/ and host/c/."""
    roots = (REPO / FIRMWARE, REPO / HOST_LIBRARY)
    return {str(p.relative_to(REPO)): p.read_text(errors="replace")
            for root in roots for p in sorted([*root.rglob("*.c"), *root.rglob("*.h")])}


def role(path: str) -> str:
    """"test double", "production" or "" (unclassified) for a path under firmware/ or host/c/."""
    if path.startswith(TEST_DOUBLES):
        return "test double"
    return "production" if path.startswith(PRODUCTION) else ""


def _owner(code: str, bodies: list[c_source.Function], at: int, comment_end: int) -> str:
    """The function a citation at `at` belongs to: the one whose body holds it, or the one whose
    signature follows its comment directly; "" when neither."""
    for f in bodies:
        if f.open <= at < f.close:
            return f.name
    nxt = next((f for f in bodies if f.open > at), None)
    if nxt is None:
        return ""
    between = code[comment_end:nxt.open]
    return nxt.name if not re.search(r"[;{}#]", between) and re.search(rf"\b{nxt.name}\s*\(", between) else ""


def _flatten(comment: str) -> tuple[str, list[int]]:
    """A comment's text on one line (line breaks and their leading ` * ` become one space) and, per
    character of it, its offset in the original text."""
    flat: list[str] = []
    where: list[int] = []
    pos = 0
    for m in CONTINUATION.finditer(comment):
        flat.extend(comment[pos:m.start()])
        where.extend(range(pos, m.start()))
        flat.append(" ")
        where.append(m.start())
        pos = m.end()
    flat.extend(comment[pos:])
    where.extend(range(pos, len(comment)))
    return "".join(flat), where


def scan(sources: Mapping[str, str] | None = None) -> tuple[list[Citation], list[str]]:
    """Every mention of a TLA+ module in the sources' comments, parsed, and the mentions that could
    not be read (each a message with file and line)."""
    found: list[Citation] = []
    errors: list[str] = []
    for path, text in (c_sources() if sources is None else sources).items():
        code = c_source.code_of(text)
        bodies = c_source.functions(code)
        for offset, comment in c_source.comments(text):
            flat, where = _flatten(comment)
            for m in MENTION.finditer(flat):
                at = offset + where[m.start()]
                line = text.count("\n", 0, at) + 1
                prefix, module, rest = m.group(1), m.group(2), flat[m.end():]
                colon, space, name_of = AFTER_COLON.match(rest), AFTER_SPACE.match(rest), NAME_OF.search(flat[:m.start()])
                if module_file(module, prefix.rstrip("/")) is None:
                    errors.append(f"{path}:{line}: {prefix}{module}.tla is not a module in spec/tla or sim/tla")
                elif rest.startswith(":") and colon is None:
                    errors.append(f"{path}:{line}: cannot read the citation `{module}.tla{rest[:20].rstrip()}`: write "
                                  f"`{module}.tla: Action` (an action of the module) or `{module}.tla Name` (a reference)")
                elif colon:
                    found.append(Citation("implements", module, colon.group(1), path, line,
                                          _owner(code, bodies, at, offset + len(comment))))
                elif space:
                    found.append(Citation("refers", module, space.group(1), path, line, ""))
                elif name_of:
                    found.append(Citation("refers", module, name_of.group(1), path, line, ""))
                else:
                    found.append(Citation("module", module, "", path, line, ""))
    return found, errors


def citations(sources: Mapping[str, str] | None = None) -> list[Citation]:
    """Every parsed mention (see scan)."""
    return scan(sources)[0]


# =============================================================================== checks


def home_of(module: str, action: str) -> str:
    """The folder whose production C implements `action` of `module` ("" when no folder does)."""
    return HOST_HOME if action in BY_HOST.get(module, set()) else MODULE_HOME.get(module, "")


def _citation_problems(c: Citation, acts: Mapping[str, list[str]], known: Mapping[str, set[str]]) -> list[str]:
    where = f"{c.path}:{c.line}"
    if c.kind == "module":
        return []
    if c.kind == "refers":
        if c.name not in known[c.module]:
            return [f"{where}: `{c.module}.tla {c.name}` names nothing {c.module}.tla defines (misspelt?)"]
        return []
    if c.module not in acts:
        return [f"{where}: `{c.module}.tla: {c.name}`: {c.module} is not a model the firmware implements "
                "(spec/tla); cite it as a reference `{c.module}.tla {c.name}`"]
    if c.name not in acts[c.module]:
        what = "an operator, not an action" if c.name in known[c.module] else "nothing the module defines (misspelt?)"
        return [f"{where}: `{c.module}.tla: {c.name}` names {what}: an implementation citation names an action of "
                f"{c.module}.tla ({', '.join(acts[c.module])}); for another definition write `{c.module}.tla {c.name}`"]
    if role(c.path) != "production":
        return []
    if not c.path.endswith(".c"):
        return [f"{where}: `{c.module}.tla: {c.name}` in a header: a header declares, the .c that does the step "
                f"implements it; write a reference `{c.module}.tla {c.name}` here"]
    home = home_of(c.module, c.name)
    if not c.path.startswith(home):
        return [f"{where}: `{c.module}.tla: {c.name}` outside {home}, where {c.module}.tla is implemented: code that "
                f"calls or observes the action writes a reference `{c.module}.tla {c.name}`"]
    if not c.function:
        return [f"{where}: `{c.module}.tla: {c.name}` is neither in a function nor in the comment right above one: "
                "put it at the code that does the step"]
    return []


def problems(sources: Mapping[str, str] | None = None) -> list[str]:
    """Everything wrong with the citations: unreadable ones, wrong names, implementations outside
    production code or counted twice, and actions nobody implements."""
    srcs = c_sources() if sources is None else dict(sources)
    found, out = scan(srcs)
    out += [f"{p}: not classified as production or test double (tools/tla_xref.py PRODUCTION, TEST_DOUBLES)"
            for p in srcs if not role(p)]
    acts = {m: actions(m) for m in specified_modules()}
    known = {c.module: names(c.module) for c in found if c.kind != "module"}
    for c in found:
        out += _citation_problems(c, acts, known)
    impl = implementations(found)
    for module, module_actions in acts.items():
        app, env = BY_APPLICATION.get(module, set()), BY_ENVIRONMENT.get(module, {})
        for stale in sorted((set(app) | set(env) | BY_HOST.get(module, set())) - set(module_actions)):
            out.append(f"tools/tla_xref.py: {module}.{stale} is listed as done outside the firmware but is no "
                       "action of the model: update BY_APPLICATION / BY_ENVIRONMENT / BY_HOST")
        for action in module_actions:
            files = impl.get((module, action), {})
            if len(files) > 1:
                out.append(f"spec/tla/{module}.tla: action {action} has {len(files)} production implementations "
                           f"({', '.join(sorted(files))}): one file does it, the others cite it as a reference")
            elif files and (action in app or action in env):
                out.append(f"spec/tla/{module}.tla: action {action} is cited as implemented in {next(iter(files))} "
                           "but listed as the application's or environment's in tools/tla_xref.py")
            elif not files and action not in app and action not in env:
                out.append(f"spec/tla/{module}.tla: action {action} has no production C citing `{module}.tla: "
                           f"{action}` (nor is it listed as the application's or environment's)")
    for module in MODULE_HOME.keys() - set(acts):
        out.append(f"tools/tla_xref.py: MODULE_HOME names {module}, which is not a model in spec/tla")
    return out


def implementations(found: list[Citation]) -> dict[tuple[str, str], dict[str, list[str]]]:
    """(module, action) -> production file -> its functions citing the action, in citation order.
    Only well-placed implementation citations count (production .c, in the module's home)."""
    out: dict[tuple[str, str], dict[str, list[str]]] = defaultdict(dict)
    for c in found:
        if (c.kind == "implements" and role(c.path) == "production" and c.path.endswith(".c")
                and c.path.startswith(home_of(c.module, c.name) or "\0") and c.function):
            fns = out[(c.module, c.name)].setdefault(c.path, [])
            if c.function not in fns:
                fns.append(c.function)
    return out


def table(sources: Mapping[str, str] | None = None) -> str:
    """Markdown table: module, action, the production file and functions that implement it."""
    impl = implementations(citations(sources))
    lines = ["| module | action | implemented at |", "|---|---|---|"]
    for module in specified_modules():
        for action in actions(module):
            files = impl.get((module, action))
            if files:
                cell = "; ".join(f"`{f}`: " + ", ".join(f"`{fn}`" for fn in fns) for f, fns in sorted(files.items()))
            elif action in BY_APPLICATION.get(module, set()):
                cell = "application code, through the locked buffer"
            elif action in BY_ENVIRONMENT.get(module, {}):
                cell = f"not firmware: {BY_ENVIRONMENT[module][action]}"
            else:
                cell = "**nobody** (tools/tla_xref.py fails)"
            lines.append(f"| {module} | {action} | {cell} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--table", action="store_true", help="print the action -> C table (markdown)")
    args = parser.parse_args()
    if args.table:
        print(table(), end="")
        return 0
    bad = problems()
    for p in bad:
        print(p, file=sys.stderr)
    found = citations()
    print(f"tla_xref: {sum(c.kind == 'implements' for c in found)} implementation citations, "
          f"{sum(c.kind == 'refers' for c in found)} references, {sum(c.kind == 'module' for c in found)} module "
          f"mentions checked; {len(bad)} problem(s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
