"""tools/setup.sh on Debian's own interpreter (issue #35): a stock /usr/bin/python3 refuses
`pip install` outside a virtual environment (PEP 668), so setup must install the Python side into
the checkout's .venv/. The test clones this commit into a fresh folder and runs setup there with
nothing but the system's directories on PATH (no pyenv, no other venv), then uses what it made."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STOCK = Path("/usr/bin/python3")
STOCK_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"

pytestmark = pytest.mark.slow


def _stock_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in {"VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME"}}
    env["PATH"] = STOCK_PATH
    env["URB_SETUP_SKIP_APT"] = "1"  # the Debian packages are this machine's already; only Python is tested
    return env


@pytest.fixture(scope="module")
def stock_clone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    assert STOCK.is_file(), "this test needs Debian's python3 at /usr/bin/python3 (tools/setup.sh installs it)"
    dest = tmp_path_factory.mktemp("stock") / "urb"
    # the working tree as it is (committed or not), so the test checks the setup under test
    subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(ROOT), str(dest)], check=True)
    changed = subprocess.run(["git", "ls-files", "--modified", "--others", "--exclude-standard"], cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout.split()
    for rel in changed:
        if (ROOT / rel).is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            (dest / rel).write_bytes((ROOT / rel).read_bytes())
    proc = subprocess.run(["bash", "tools/setup.sh"], cwd=dest, env=_stock_env(), capture_output=True,
                          text=True, timeout=1200)
    assert proc.returncode == 0, f"setup.sh failed on the stock interpreter:\n{proc.stdout}\n{proc.stderr}"
    return dest


def test_the_stock_interpreter_refuses_a_system_install() -> None:
    """The situation the fix is for: without a virtual environment pip is refused (PEP 668)."""
    marker = list(Path("/usr/lib").glob("python3*/EXTERNALLY-MANAGED"))
    assert marker, "Debian's python3 is not marked externally managed here: the test would prove nothing"
    proc = subprocess.run([str(STOCK), "-m", "pip", "install", "--dry-run", "--no-deps", "--no-index", "lark"],
                          env=_stock_env(), capture_output=True, text=True)
    assert proc.returncode != 0 and "externally-managed-environment" in proc.stdout + proc.stderr


def test_setup_makes_a_venv_from_the_stock_interpreter(stock_clone: Path) -> None:
    cfg = (stock_clone / ".venv" / "pyvenv.cfg").read_text()
    assert "home = /usr/bin" in cfg, cfg
    proc = subprocess.run([str(stock_clone / ".venv" / "bin" / "urb"), "--version"], env=_stock_env(),
                          capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.startswith("urb "), proc.stdout + proc.stderr
    where = subprocess.run([str(stock_clone / ".venv" / "bin" / "python"), "-c", "import urb; print(urb.__file__)"],
                           capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).resolve().is_relative_to(stock_clone.resolve()), where


def test_setup_is_a_quick_no_op_the_second_time(stock_clone: Path) -> None:
    proc = subprocess.run(["bash", "tools/setup.sh"], cwd=stock_clone, env=_stock_env(), capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout == "", proc.stdout + proc.stderr


def test_make_targets_run_the_venv(stock_clone: Path) -> None:
    """The Makefile puts .venv/bin first: the python3 a recipe runs is the venv's."""
    proc = subprocess.run(["make", "-s", "--no-print-directory", "-f", "Makefile", "-f", "-", "which-python"],
                          input="which-python:\n\t@python3 -c 'import sys; print(sys.prefix)'\n",
                          cwd=stock_clone, env=_stock_env(), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert Path(proc.stdout.strip()) == stock_clone / ".venv", proc.stdout
