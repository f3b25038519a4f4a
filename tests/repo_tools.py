"""Load one of the repository's tool scripts (tools/*.py, proof folders' prepare.py) as a module.

The scripts are programs, not an installed package, so tests import them by path. The module is
registered in sys.modules under `name` before it runs: dataclasses look their module up there."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def load_module(name: str, path: Path) -> ModuleType:
    """Import the script at `path` (absolute, or relative to the repository) as module `name`."""
    spec = importlib.util.spec_from_file_location(name, path if path.is_absolute() else ROOT / path)
    assert spec is not None and spec.loader is not None, f"cannot load {path}"
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
