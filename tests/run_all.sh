#!/usr/bin/env bash
# The whole test suite: Rust tests, then the fmpy cross-checks of the packaged FMUs.
# Installs fmpy into a local virtual environment (.venv) on first use.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== build (release) =="
cargo build --release --workspace --locked

echo "== Rust tests =="
cargo test --release --workspace --locked

echo "== Python environment =="
if [ ! -x .venv/bin/python ] || ! .venv/bin/python -c "import fmpy, pytest" 2>/dev/null; then
    python3 -m venv .venv
    .venv/bin/pip install --quiet --disable-pip-version-check -r tests/requirements.txt
fi

# The fmpy cross-checks (tests/python) join here once the FMUs are packaged (issue 4).
.venv/bin/python -c "import fmpy; print('fmpy', fmpy.__version__, 'ready')"
