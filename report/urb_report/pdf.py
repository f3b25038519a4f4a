"""HTML to PDF with headless Chromium (Debian's `chromium`), no network, a fresh profile per run."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path


class PdfError(Exception):
    """Chromium is missing or did not write the PDF; the message says what to do."""


FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-pdf-header-footer")


def chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return found
    raise PdfError("chromium is not installed: run `make setup` (tools/setup.sh installs Debian's chromium) or "
                   "`apt-get install chromium`; the HTML report is written anyway")


def print_pdf(html: Path, pdf: Path, timeout_s: float = 180.0) -> Path:
    """Print `html` to `pdf`; raises PdfError with Chromium's output when it fails."""
    exe = chromium()
    pdf.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="urb-chromium-") as profile:
        argv = [exe, *FLAGS, f"--user-data-dir={profile}", f"--print-to-pdf={pdf}", html.resolve().as_uri()]
        try:
            proc = subprocess.run(argv, capture_output=True, text=True, timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired as exc:
            raise PdfError(f"chromium did not finish printing {html} in {timeout_s:.0f} s") from exc
    if proc.returncode != 0 or not pdf.is_file() or pdf.stat().st_size == 0:
        tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-8:])
        raise PdfError(f"chromium did not write {pdf} (exit {proc.returncode}):\n{tail}")
    return pdf
