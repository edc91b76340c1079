"""Shared fixtures: the compiled scene, its planar arm, and a reachability table cached per session."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "disable")

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
