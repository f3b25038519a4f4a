"""Schema errors that point at file:line:column with a caret and a one-line fix hint."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Location:
    """A position in a schema file (1-based line and column)."""

    path: Path
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.column}"


class SchemaError(Exception):
    """A problem in a schema file; `render()` shows it the way a compiler would."""

    def __init__(self, location: Location, message: str, hint: str, *, related: Location | None = None,
                 message_there: str | None = None) -> None:
        """`related` is the other place of a conflict (the other declaration of a name); `message_there`
        tells the same conflict from there, for a check of that file (see `seen_from`)."""
        super().__init__(f"{location}: error: {message}")
        self.location = location
        self.message = message
        self.hint = hint
        self.related = related
        self.message_there = message_there

    def seen_from(self, path: Path) -> SchemaError:
        """This error told from `path`: itself, or, when only its related place is in `path`, the same
        conflict located there (what `urb schema check FILE` shows when FILE holds the first declaration)."""
        if self.related is None or self.message_there is None or _same(self.location.path, path) \
                or not _same(self.related.path, path):
            return self
        return SchemaError(self.related, self.message_there, self.hint, related=self.location, message_there=self.message)

    def involves(self, path: Path) -> bool:
        """Whether the error is located in `path` or names a place in it as the other side of a conflict."""
        return _same(self.location.path, path) or (self.related is not None and _same(self.related.path, path))

    def render(self, source: str | None = None) -> str:
        """Format as `file:line:col: error: msg`, the source line, a caret and the hint; then the other
        place of a conflict as `file:line:col: note:` with its line and caret."""
        out = [f"{self.location}: error: {self.message}", *_quote(self.location, source), f"  hint: {self.hint}"]
        if self.related is not None:
            out += [f"{self.related}: note: the other declaration", *_quote(self.related, None)]
        return "\n".join(out)


def _same(a: Path, b: Path) -> bool:
    return a == b or a.resolve() == b.resolve()


def _quote(location: Location, source: str | None) -> list[str]:
    """The source line at `location` and a caret under its column (nothing when the line is not there)."""
    if source is None:
        try:  # undecodable bytes shown as U+FFFD: the error may be that the file is not UTF-8
            source = location.path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            source = ""
    lines = source.splitlines()
    if not 1 <= location.line <= len(lines):
        return []
    text = lines[location.line - 1].replace("\t", " ")
    return [f"    {text}", "    " + " " * (max(location.column, 1) - 1) + "^"]


class SchemaErrors(Exception):
    """Several independent schema errors found in one pass."""

    def __init__(self, errors: list[SchemaError]) -> None:
        super().__init__("\n".join(str(e) for e in errors))
        self.errors = errors

    def render(self) -> str:
        """All errors, rendered, separated by blank lines."""
        return "\n\n".join(e.render() for e in self.errors)
