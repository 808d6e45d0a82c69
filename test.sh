#!/usr/bin/env bash
# The one test command of pbd (README, Quick start; .ci/run runs it): the Rust tests of the workspace,
# then the Python module built from this checkout and its pytest suite in a virtual environment.
#
#   ./test.sh            # both
#   PBD_TEST=rust ./test.sh   or   PBD_TEST=python ./test.sh   # one of them
#
# The venv is $PBD_VENV (default .venv-test in the repository); it is reused between runs.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
what="${PBD_TEST:-all}"

python="${PYTHON:-python3}"
venv="${PBD_VENV:-.venv-test}"

# The Python module (crates/py) in the venv with its test dependencies: pip's installs wait on the
# network and the module's build reuses what the Rust tests compiled, so with both suites it runs
# beside the Rust tests (cargo holds no lock while tests run), its output kept for after them.
python_setup() {
    if [ ! -x "$venv/bin/python" ]; then
        "$python" -m venv "$venv"
    fi
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet pytest numpy
    # Cyclone DDS: the ROS 2 conformance test's peer (without it that test skips with a message).
    "$venv/bin/python" -m pip install --quiet "cyclonedds>=0.10" || echo "WARNING: cyclonedds did not install; the ROS 2 conformance test will be SKIPPED" >&2
    # rosbags (rosbag2 in pure Python), Foxglove's mcap reader and its ROS 2 decoder: the ROS 2
    # recording test's readers.
    "$venv/bin/python" -m pip install --quiet "rosbags>=0.10" "mcap>=1.1" "mcap-ros2-support>=0.5" || echo "WARNING: rosbags/mcap did not install; the ROS 2 recording test will be SKIPPED" >&2
    # Ray is large; without it the Ray test skips with a message.
    "$venv/bin/python" -m pip install --quiet "ray>=2.40" || echo "WARNING: ray did not install; the Ray test will be SKIPPED" >&2
    # The module is built in the repository's target directory, so it reuses what the Rust tests built.
    CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}" \
        "$venv/bin/python" -m pip install --quiet --force-reinstall --no-deps ./crates/py
}

setup_pid=""
setup_log=""
if [ "$what" = all ] || [ "$what" = rust ]; then
    echo "== [${SECONDS} s] Rust tests: build"
    cargo test --workspace --release --no-run
    if [ "$what" = all ]; then
        echo "== [${SECONDS} s] Python module (crates/py) and its test dependencies: set up beside the Rust tests"
        setup_log="$(mktemp)"
        python_setup > "$setup_log" 2>&1 &
        setup_pid=$!
    fi
    echo "== [${SECONDS} s] Rust tests: run"
    rust_status=0
    cargo test --workspace --release || rust_status=$?
    if [ -n "$setup_pid" ]; then
        setup_status=0
        wait "$setup_pid" || setup_status=$?
        echo "== [${SECONDS} s] Python set-up's output:"
        cat "$setup_log"
        rm -f "$setup_log"
        if [ "$setup_status" != 0 ]; then
            echo "the Python module's set-up failed (exit $setup_status)" >&2
            exit "$setup_status"
        fi
    fi
    if [ "$rust_status" != 0 ]; then
        exit "$rust_status"
    fi
fi

if [ "$what" = all ] || [ "$what" = python ]; then
    if [ -z "$setup_pid" ]; then
        echo "== [${SECONDS} s] Python module (crates/py) and its test dependencies"
        python_setup
    fi
    echo "== [${SECONDS} s] pytest"
    "$venv/bin/python" -m pytest -q -rs crates/py/tests
fi
