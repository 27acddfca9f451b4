#!/usr/bin/env bash
# The whole test suite: formatting and lints, Rust tests, the Python package, then the fmpy cross-checks
# of the packaged FMUs and the runs of our SSP files in co-simulation engines we did not write (libcosim,
# ecos).
# Installs tests/requirements.txt into a local virtual environment (.venv), and keeps it current.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== format and lints =="
cargo fmt --all --check
cargo clippy --workspace --all-targets --release --locked -- -D warnings

echo "== build (release) =="
cargo build --release --workspace --locked

echo "== Rust tests =="
cargo test --release --workspace --locked

echo "== Python environment =="
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
# quick when everything pinned is there already; installs what a new pin added
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/requirements.txt

echo "== the Python package (feedsim, built from python/ into .venv) =="
# maturin is pinned in tests/requirements.txt: no build isolation, so nothing is downloaded here; the
# extension is a member of the workspace, built with its lock into the same target folder
PATH="$PWD/.venv/bin:$PATH" \
    .venv/bin/pip install --quiet --disable-pip-version-check --no-build-isolation ./python

echo "== package the FMUs =="
target_dir="${CARGO_TARGET_DIR:-target}"
"$target_dir/release/master" package --out dist

echo "== fmpy cross-checks, zoo systems, libcosim and ecos =="
.venv/bin/python -c "import fmpy; print('fmpy', fmpy.__version__)"
FMU_DIST="$PWD/dist" .venv/bin/python -m pytest -q tests/python
