"""Shared paths and fixtures of the pbd Python tests."""

import os
import pathlib
import shutil

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[2]
DATA = REPO / "tests" / "data"
BAYES_DATA = REPO / "crates" / "bayes" / "tests" / "data"
SHARED = pathlib.Path(os.environ.get("PBD_SHARED", REPO.parent / "shared")) / "reference"
MODEL = HERE / "data" / "sorting-model.json"
GRASP_MODEL = HERE / "data" / "grasp-prototypes.json"


def pbd_cli():
    """The `pbd` binary if one is built (PBD_CLI, $CARGO_TARGET_DIR/release, target/release, PATH)."""
    candidates = [os.environ.get("PBD_CLI")]
    for target in [os.environ.get("CARGO_TARGET_DIR"), REPO / "target"]:
        if target:
            candidates.append(pathlib.Path(target) / "release" / "pbd")
    candidates.append(shutil.which("pbd"))
    for c in candidates:
        if c and pathlib.Path(c).is_file() and os.access(c, os.X_OK):
            return str(c)
    return None


@pytest.fixture(scope="session")
def touch_demo(tmp_path_factory):
    """A short recorded demonstration (the scripted teacher touches an object; ~3 s)."""
    import pbd

    d = tmp_path_factory.mktemp("touch")
    path = d / "touch.mcap"
    report = pbd.record(path, script="touch", seed=3)
    return path, report
