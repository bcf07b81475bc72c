#!/usr/bin/env bash
# The Python-side tests (tests/python/): interoperability with meshio, gmsh and jsonschema, and
# the `wsm` Python package (crates/python) when it is there.
#
#   scripts/python_tests.sh [PATH/TO/wsm]      (default: target/release/wsm; builds no binary)
#
# Makes a virtual environment with the pinned scripts/python-requirements.txt (PyPI only; the
# gmsh wheel carries its own library) in target/py-venv (override with WSM_PY_VENV), installs the
# package from crates/python with pip (maturin builds it with cargo), and runs pytest with
# WSM_BIN set to the binary. Exit status: pytest's.
set -euo pipefail

cd "$(dirname "$0")/.."
ROOT=$(pwd)
WSM=${1:-target/release/wsm}
[[ $# -gt 0 ]] && shift
VENV=${WSM_PY_VENV:-$ROOT/target/py-venv}
REQUIREMENTS=$ROOT/scripts/python-requirements.txt

if [[ ! -x $WSM ]]; then
    echo "python_tests: no wsm binary at $WSM (build it first: cargo build --release)" >&2
    exit 2
fi
export WSM_BIN
WSM_BIN=$(cd "$(dirname "$WSM")" && pwd)/$(basename "$WSM")

export PATH="$VENV/bin:$PATH"
stamp=$(sha256sum "$REQUIREMENTS" | cut -c1-16)
if [[ ! -x $VENV/bin/python || $(cat "$VENV/.requirements" 2>/dev/null) != "$stamp" ]]; then
    echo "python_tests: preparing the Python environment in $VENV"
    rm -rf "$VENV"
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -q --disable-pip-version-check -r "$REQUIREMENTS"
    echo "$stamp" > "$VENV/.requirements"
fi

if [[ -f crates/python/pyproject.toml ]]; then
    echo "python_tests: building and installing the wsm package (pip install crates/python)"
    "$VENV/bin/pip" install -q --disable-pip-version-check --no-build-isolation crates/python
fi

cd "$ROOT"
exec "$VENV/bin/python" -m pytest -q -p no:cacheprovider tests/python
