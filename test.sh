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

if [ "$what" = all ] || [ "$what" = rust ]; then
    echo "== [${SECONDS} s] Rust tests: build"
    cargo test --workspace --release --no-run
    echo "== [${SECONDS} s] Rust tests: run"
    cargo test --workspace --release
fi

if [ "$what" = all ] || [ "$what" = python ]; then
    echo "== [${SECONDS} s] Python module (crates/py) and its tests"
    python="${PYTHON:-python3}"
    venv="${PBD_VENV:-.venv-test}"
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
    echo "== [${SECONDS} s] pytest"
    "$venv/bin/python" -m pytest -q -rs crates/py/tests
fi
