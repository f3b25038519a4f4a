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

    def __init__(self, location: Location, message: str, hint: str) -> None:
        super().__init__(f"{location}: error: {message}")
        self.location = location
        self.message = message
        self.hint = hint

    def render(self, source: str | None = None) -> str:
        """Format as `file:line:col: error: msg`, the source line, a caret, and the hint."""
        if source is None:
            try:  # undecodable bytes shown as U+FFFD: the error may be that the file is not UTF-8
                source = self.location.path.read_text(encoding="utf-8", errors="replace")
            except OSError:
                source = ""
        lines = source.splitlines()
        out = [f"{self.location}: error: {self.message}"]
        if 1 <= self.location.line <= len(lines):
            text = lines[self.location.line - 1].replace("\t", " ")
            out.append(f"    {text}")
            out.append("    " + " " * (max(self.location.column, 1) - 1) + "^")
        out.append(f"  hint: {self.hint}")
        return "\n".join(out)


class SchemaErrors(Exception):
    """Several independent schema errors found in one pass."""

    def __init__(self, errors: list[SchemaError]) -> None:
        super().__init__("\n".join(str(e) for e in errors))
        self.errors = errors

    def render(self) -> str:
        """All errors, rendered, separated by blank lines."""
        return "\n\n".join(e.render() for e in self.errors)
