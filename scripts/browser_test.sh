#!/usr/bin/env bash
# End-to-end test of the web dashboard in headless Chromium (tests/browser/test_dashboard.py).
#
#   scripts/browser_test.sh [PATH/TO/wsm]      (default: target/release/wsm; builds nothing)
#
# Installs what is missing: Debian's chromium (apt, only if /usr/bin/chromium is absent) and a
# Python virtual environment with pinned Playwright and pytest (never `playwright install`: the
# browser is the system one). Starts `wsm serve` on a free loopback port with a temporary
# database, runs the tests, stops the server. Screenshots and the downloaded result go to
# target/browser-artifacts/ (override with WSM_ARTIFACTS). Exit status: pytest's.
set -euo pipefail

cd "$(dirname "$0")/.."
ROOT=$(pwd)
WSM=${1:-target/release/wsm}
VENV=${WSM_BROWSER_VENV:-$ROOT/target/browser-venv}
ARTIFACTS=${WSM_ARTIFACTS:-$ROOT/target/browser-artifacts}
PLAYWRIGHT_VERSION=1.65.2
PYTEST_VERSION=9.2.0

if [[ ! -x $WSM ]]; then
    echo "browser_test: no wsm binary at $WSM (build it first: cargo build --release)" >&2
    exit 2
fi
WSM=$(cd "$(dirname "$WSM")" && pwd)/$(basename "$WSM")

if [[ ! -x /usr/bin/chromium ]]; then
    echo "browser_test: installing chromium (apt)"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq chromium >/dev/null
fi

if ! "$VENV/bin/python" -c "import playwright, pytest" 2>/dev/null \
    || [[ $("$VENV/bin/python" -c 'from importlib.metadata import version; print(version("playwright"), version("pytest"))') != "$PLAYWRIGHT_VERSION $PYTEST_VERSION" ]]; then
    echo "browser_test: preparing the Python environment in $VENV"
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -q --disable-pip-version-check \
        "playwright==$PLAYWRIGHT_VERSION" "pytest==$PYTEST_VERSION"
fi

WORK=$(mktemp -d -t wsm-browser-XXXXXX)
SERVER_PID=
FAULT_PID=
TOKEN_PID=
cleanup() {
    for pid in $SERVER_PID $FAULT_PID $TOKEN_PID; do
        kill "$pid" 2>/dev/null || true
        wait "$pid" 2>/dev/null || true
    done
    rm -rf "$WORK"
}
trap cleanup EXIT

rm -rf "$ARTIFACTS"
mkdir -p "$ARTIFACTS"
START=$(date +%s)

# start_server NAME TOKEN [ARGS...]: `wsm serve` on a free port (port 0: it prints the port on
# its first line) with its own database and WSM_API_TOKEN=TOKEN (empty: none); sets URL and PID.
start_server() {
    local name=$1 token=$2
    shift 2
    # Created before the server starts, so reading it cannot race the background redirection.
    : >"$WORK/$name.out"
    env -u WSM_API_TOKEN ${token:+WSM_API_TOKEN="$token"} "$WSM" serve --addr 127.0.0.1:0 \
        --db "$WORK/$name.db" --workers 1 --threads-per-job 1 "$@" \
        >"$WORK/$name.out" 2>"$ARTIFACTS/$name-server.log" &
    PID=$!
    URL=
    for _ in $(seq 1 100); do
        URL=$(sed -n 's|.*serving \(http://[0-9.:]*\)/.*|\1|p' "$WORK/$name.out" | head -n 1)
        [[ -n $URL ]] && break
        if ! kill -0 "$PID" 2>/dev/null; then
            echo "browser_test: wsm serve ($name) exited:" >&2
            cat "$ARTIFACTS/$name-server.log" >&2
            exit 1
        fi
        sleep 0.1
    done
    if [[ -z $URL ]]; then
        echo "browser_test: wsm serve ($name) did not report its address" >&2
        exit 1
    fi
    echo "browser_test: wsm serve ($name) at $URL (pid $PID)"
}

start_server jobs ""
SERVER_PID=$PID
MAIN_URL=$URL
# A second server whose evaluations fail above a traction and whose accuracy statements' refined
# solves all fail (the failure-reporting tests).
start_server faults "" --inject-failures 'boundary[2].traction[0]=375000' \
    --inject-failures 'refined:materials.rock.E=0'
FAULT_PID=$PID
FAULT_URL=$URL
# A third server that requires a token, also for reads (the access test).
start_server token browser-secret
TOKEN_PID=$PID
TOKEN_URL=$URL

set +e
WSM_URL=$MAIN_URL WSM_FAULT_URL=$FAULT_URL WSM_TOKEN_URL=$TOKEN_URL WSM_ARTIFACTS=$ARTIFACTS "$VENV/bin/python" -m pytest -q -p no:cacheprovider \
    tests/browser/test_dashboard.py 2>&1 | tee "$ARTIFACTS/pytest.log"
STATUS=${PIPESTATUS[0]}
set -e

echo "browser_test: $(tail -n 1 "$ARTIFACTS/pytest.log") — $(($(date +%s) - START)) s; artefacts in $ARTIFACTS"
exit "$STATUS"
