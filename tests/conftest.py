"""Shared fixtures: the compiled scene, its planar arm, and a reachability table cached per session; and,
at the end of the session, a check that no process excavsim started is left running."""

from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "disable")
# Every process this test process starts, and every process they start, carries this session's mark
# (each pytest-xdist worker has its own): the check at the end looks for the processes of this session only.
SESSION = "EXCAVSIM_TEST_SESSION"
os.environ[SESSION] = str(os.getpid())

import mujoco  # noqa: E402
import pytest  # noqa: E402

from excavsim import constants  # noqa: E402
from excavsim.robot.extract import arm_from_model
from excavsim.robot.kinematics import PlanarArm  # noqa: E402


@pytest.fixture(scope="session")
def mj_model() -> mujoco.MjModel:
    """The Menagerie scene compiled straight from XML (no configuration applied)."""
    return mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))


@pytest.fixture(scope="session")
def arm(mj_model) -> PlanarArm:
    return arm_from_model(mj_model)


@pytest.fixture(scope="session")
def reach_table(arm, tmp_path_factory):
    from excavsim.robot.reachability import load_or_build

    return load_or_build(arm, cache_dir=tmp_path_factory.mktemp("reach-cache"))


@pytest.fixture()
def rng():
    import numpy as np

    return np.random.default_rng(20261122)


@pytest.fixture(scope="session", autouse=True)
def no_process_left_behind():
    """At the end of the session, no process that excavsim started (an OwnedProcess: a viewer, a
    verify, another checkout's run), here or in a command a test ran, is still running: such a
    process is killed and the session's last test fails with its command line."""
    yield
    if not sys.platform.startswith("linux"):  # found through /proc
        return
    from excavsim.processes import STARTED_BY
    from tests.children import command_line, kill, wait_gone, with_environment

    started = set(with_environment(STARTED_BY))
    mine = [p for p in with_environment(SESSION, os.environ[SESSION]) if p in started]
    left = wait_gone(mine)
    lines = [command_line(p[0]) for p in left]
    kill(left)
    assert not left, f"processes excavsim started and left running: {lines}"
