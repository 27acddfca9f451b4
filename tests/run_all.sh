#!/usr/bin/env bash
# The whole test suite: formatting and lints, Rust tests, the Python package, then the fmpy cross-checks
# of the packaged FMUs and the runs of our SSP files in co-simulation engines we did not write (libcosim,
# ecos).
# Installs tests/requirements.txt into a local virtual environment (.venv), and keeps it current.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== format and lints =="
cargo fmt --all --check
cargo fmt --manifest-path python/Cargo.toml --check
cargo clippy --workspace --all-targets --release --locked -- -D warnings
# the Python package's extension is its own workspace (python/Cargo.toml), with a target folder of its
# own: two workspaces in one folder can leave a crate built against another's copy of a dependency
python_target="${CARGO_TARGET_DIR:-$PWD/target}/python"
CARGO_TARGET_DIR="$python_target" cargo clippy --manifest-path python/Cargo.toml --release --locked -- -D warnings

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
# maturin is pinned in tests/requirements.txt: no build isolation, so nothing is downloaded here
PATH="$PWD/.venv/bin:$PATH" CARGO_TARGET_DIR="$python_target" \
    .venv/bin/pip install --quiet --disable-pip-version-check --no-build-isolation ./python

echo "== package the FMUs =="
target_dir="${CARGO_TARGET_DIR:-target}"
"$target_dir/release/master" package --out dist

echo "== fmpy cross-checks, zoo systems, libcosim and ecos =="
.venv/bin/python -c "import fmpy; print('fmpy', fmpy.__version__)"
FMU_DIST="$PWD/dist" .venv/bin/python -m pytest -q tests/python
