"""One home for model paths and the MJCF names the code refers to.

A test checks that every name here exists in the compiled scene (tests/world/test_models.py).
"""

from __future__ import annotations

import pathlib

PACKAGE_ROOT = pathlib.Path(__file__).resolve().parent
REPO_ROOT = PACKAGE_ROOT.parent
MODELS_DIR = REPO_ROOT / "models"
CONFIGS_DIR = REPO_ROOT / "configs"

T3_XML = MODELS_DIR / "t3" / "t3.xml"
SCENE_XML = MODELS_DIR / "t3" / "scene.xml"
SOIL_BOX_XML = MODELS_DIR / "soil_box" / "soil_box.xml"
ROBOT_YAML = CONFIGS_DIR / "robot.yaml"
SCENE_YAML = CONFIGS_DIR / "scene.yaml"
SOILS_YAML = CONFIGS_DIR / "soils.yaml"
SENSING_YAML = CONFIGS_DIR / "sensing.yaml"
PLANNER_YAML = CONFIGS_DIR / "planner.yaml"
EXECUTOR_YAML = CONFIGS_DIR / "executor.yaml"
TRENCHES_DIR = CONFIGS_DIR / "trenches"

# Joints, in qpos order; actuators carry the joint name without the suffix (Menagerie convention).
JOINTS = ("waist_joint", "shoulder_joint", "elbow_joint", "wrist_pitch_joint", "wrist_yaw_joint", "wrist_roll_joint")
ACTUATORS = tuple(j.removesuffix("_joint") for j in JOINTS)
# The planar digging chain (Singh 1995 §4.3.3: only these move while digging).
PLANAR_JOINTS = ("shoulder_joint", "elbow_joint", "wrist_pitch_joint")
WAIST_JOINT = "waist_joint"

BUCKET_BODY = "bucket"
BUCKET_TIP_SITE = "bucket_tip"
FT_SITE = "ft_mount"
FT_FORCE_SENSOR = "ft_force"
FT_TORQUE_SENSOR = "ft_torque"
BUCKET_PROFILE_SITE_PREFIX = "bucket_profile_"
N_BUCKET_PROFILE_SITES = 7
BUCKET_WIDTH_NUMERIC = "bucket_width"
BUCKET_CAPACITY_NUMERIC = "bucket_capacity"

SOIL_HFIELD = "soil"
SOIL_GEOM = "soil"
SOIL_BOX_BODY = "soil_box"
SCANNER_SITE = "scanner"
SURVEY_TARGET_SITE_PREFIX = "survey_target_"
N_SURVEY_TARGETS = 8

KEYFRAMES = ("home", "park")
