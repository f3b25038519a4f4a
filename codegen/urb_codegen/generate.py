"""Generate every codec from the schemas, or check that the committed output is fresh."""

from __future__ import annotations

import filecmp
import tempfile
from dataclasses import dataclass
from pathlib import Path

from .model import Schema
from .parser import load

REPO = Path(__file__).resolve().parents[2]
SCHEMA_DIR = REPO / "spec" / "schema"
C_DIR = REPO / "gen" / "c"
PY_DIR = REPO / "gen" / "python" / "urb_msgs"


def schema_files(schema_dir: Path = SCHEMA_DIR) -> list[Path]:
    """The bundled *.urbs files, sorted."""
    return sorted(schema_dir.glob("*.urbs"))


def load_bundled(schema_dir: Path = SCHEMA_DIR) -> list[Schema]:
    """Load and check every schema in `schema_dir`."""
    return load(schema_files(schema_dir))


def generate(schemas: list[Schema], c_dir: Path = C_DIR, py_dir: Path = PY_DIR) -> list[Path]:
    """Write C and Python codecs; return every file written."""
    from .emit_c import emit_c  # the emitters load templates; `schema check` and `show` need neither
    from .emit_py import emit_python

    return [*emit_c(schemas, c_dir), *emit_python(schemas, py_dir)]


@dataclass(frozen=True)
class Staleness:
    """Differences between committed generated files and what the schemas generate now."""

    changed: list[Path]
    missing: list[Path]
    extra: list[Path]

    @property
    def fresh(self) -> bool:
        return not (self.changed or self.missing or self.extra)


def _tree(root: Path) -> set[Path]:
    if not root.exists():
        return set()
    return {p.relative_to(root) for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts}


def check_fresh(schemas: list[Schema], c_dir: Path = C_DIR, py_dir: Path = PY_DIR) -> Staleness:
    """Generate into a temporary folder and compare it with the committed output."""
    changed: list[Path] = []
    missing: list[Path] = []
    extra: list[Path] = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp_c, tmp_py = Path(tmp) / "c", Path(tmp) / "py"
        generate(schemas, tmp_c, tmp_py)
        for fresh_root, committed_root in ((tmp_c, c_dir), (tmp_py, py_dir)):
            want, have = _tree(fresh_root), _tree(committed_root)
            missing += [committed_root / p for p in sorted(want - have)]
            extra += [committed_root / p for p in sorted(have - want)]
            changed += [
                committed_root / p for p in sorted(want & have)
                if not filecmp.cmp(fresh_root / p, committed_root / p, shallow=False)
            ]
    return Staleness(changed, missing, extra)
