#!/usr/bin/env bash
# Installs everything the tests need on a fresh Debian machine and runs every
# test: the Rust workspace (cargo test) and the Python package (pytest,
# including the report in headless Chromium).
#
# Debian packages (installed only when missing): chromium for the browser
# test; for the polyscope viewer's headless (EGL) screenshots, Mesa's EGL/GL
# (libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri) and libx11-6, which polyscope's
# module links. Checked by hiding libraries: polyscope falls back from
# libEGL.so/libOpenGL.so.0/libGL.so to libEGL.so.1 and libGL.so.1, so neither
# the -dev packages nor libopengl0 are needed. Mesa's software renderer is
# enough: no GPU, no display.
# Python packages: the selfcd package itself (pip install ., which builds the
# Rust extension with maturin) and its test extras (pytest, playwright, pillow,
# polyscope, usd-core, ray (the Ray test starts a small local head on 127.0.0.1),
# and ruff and mypy for the gates).
# Gates, run after the tests: cargo fmt --check, cargo clippy -D warnings,
# cargo doc with warnings as errors (broken or private links in the API
# docs), ruff (configured in pyproject.toml) and mypy's stubtest of
# selfcd._core against python/selfcd/_core.pyi.
# No browser is downloaded: playwright drives Debian's /usr/bin/chromium.
set -euo pipefail
cd "$(dirname "$0")/.."

DEBS=(chromium libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri libx11-6)
missing=()
for pkg in "${DEBS[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "== apt-get install ${missing[*]}"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" </dev/null
fi

PY="${PYTHON:-python3}"
echo "== pip install .[test]"
"$PY" -m pip install --disable-pip-version-check --progress-bar off ".[test]"
command -v pyenv >/dev/null && pyenv rehash || true

# Both suites run even when the first fails; the script fails if either did.
status=0
echo "== cargo test --workspace"
cargo test --workspace || status=1

echo "== pytest"
"$PY" -m pytest -q tests || status=1

# Gates, after the tests; each runs even when an earlier one failed, and each
# failure is named at the end.
failed=()
gate() {
    local name="$1"
    shift
    echo "== gate: $name"
    "$@" || failed+=("$name")
}
command -v rustup >/dev/null && rustup component add rustfmt clippy >/dev/null 2>&1 || true
gate "cargo fmt --check" cargo fmt --all --check
gate "cargo clippy" cargo clippy --workspace --all-targets -- -D warnings
gate "cargo doc" env RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet
gate "ruff" "$PY" -m ruff check .
gate "stubtest" "$PY" -m mypy.stubtest selfcd._core --allowlist scripts/stubtest_allowlist.txt

[ "$status" -eq 0 ] || echo "== FAILED: see the cargo test or pytest output above" >&2
if [ ${#failed[@]} -gt 0 ]; then
    echo "== FAILED gates: ${failed[*]}" >&2
    status=1
fi
exit "$status"
