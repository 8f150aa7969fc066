#!/usr/bin/env bash
# The Python package's tests: builds the `wetcloth` package with maturin into a virtual
# environment (target/py-venv, made on first use) with the pinned test requirements, builds the
# command line the tests compare with, and runs pytest. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

venv="${WETCLOTH_VENV:-target/py-venv}"
if [ ! -x "$venv/bin/python3" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python3" -m pip install --quiet --disable-pip-version-check \
  -r crates/wetcloth-py/requirements-test.txt
cargo build --release -p wetcloth-cli
# maturin builds the extension module (PYO3_BUILD_EXTENSION_MODULE) and installs the package
# into the virtual environment, editable: python/ is used in place.
VIRTUAL_ENV="$(cd "$venv" && pwd)" "$venv/bin/maturin" develop --release --quiet \
  -m crates/wetcloth-py/Cargo.toml
"$venv/bin/python3" -m pytest crates/wetcloth-py/tests -q "$@"
