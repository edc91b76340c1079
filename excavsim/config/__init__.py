"""YAML configuration, validated on load: one module per file of ``configs/``.

Every configuration is a frozen pydantic model (:class:`StrictModel`: no unknown fields, no type
coercion, no NaN or infinity). :func:`load_config` reads a YAML file and returns the model or raises
:class:`~excavsim.errors.ConfigError` whose message names the file, the field, what was given and
what is allowed, one line per problem. Angles are in degrees in the files (the configuration edge)
and in radians in the code. Everything is importable from ``excavsim.config``:

* :mod:`~excavsim.config.loader`: the strict base model, the YAML loader (UTF-8 only; size, depth and
  alias-expansion limits; no repeated keys), the messages;
* :mod:`~excavsim.config.semantic`: checks across files after the schemas (a goal against the soil box
  and the initial soil);
* :mod:`~excavsim.config.robot`, :mod:`~excavsim.config.scene`, :mod:`~excavsim.config.soils`,
  :mod:`~excavsim.config.sensing`, :mod:`~excavsim.config.planner`, :mod:`~excavsim.config.executor`:
  ``configs/robot.yaml``, ``scene.yaml``, ``soils.yaml``, ``sensing.yaml``, ``planner.yaml`` with
  ``trenches/*.yaml``, and ``executor.yaml``;
* :mod:`~excavsim.config.baseline` (the regression baseline ``configs/regress/baseline.json``),
  :mod:`~excavsim.config.kinds` (a kind of file, as ``excavsim validate`` knows it) and
  :mod:`~excavsim.config.arguments` (the command line's argument types).

A task's own files are configured in its folder (``excavsim/tasks/<task>/config.py``).

``excavsim validate`` (:mod:`excavsim.validate`) checks a file of any kind, told from its place or its fields.
"""

from excavsim.config.baseline import RegressBaseline, load_baseline_file
from excavsim.config.executor import ExecutorConfig, load_executor_config
from excavsim.config.loader import StrictModel, display_path, load_config, parse_config, parse_yaml, read_text_file
from excavsim.config.planner import PlannerConfig, PlannerGrid, TrenchGoal, load_planner_config, load_trench_goal
from excavsim.config.robot import JointServo, JointServos, RobotConfig, load_robot_config
from excavsim.config.scene import BucketSoilConfig, SceneConfig, SettleConfig, SoilTruthConfig, load_scene_config
from excavsim.config.sensing import (ElevationMapConfig, ForceSensorConfig, ScannerConfig, SensingConfig,
                                     load_sensing_config)
from excavsim.config.semantic import check_goal
from excavsim.config.soils import DiMaioParams, SoilParams, SoilsFile, get_soil, load_soils
from excavsim.errors import ConfigError

__all__ = ["BucketSoilConfig", "ConfigError", "DiMaioParams", "ElevationMapConfig", "ExecutorConfig", "ForceSensorConfig", "JointServo", "JointServos", "PlannerConfig", "PlannerGrid", "RegressBaseline", "RobotConfig", "ScannerConfig", "SceneConfig", "SensingConfig", "SettleConfig", "SoilParams", "SoilTruthConfig", "SoilsFile", "StrictModel", "TrenchGoal", "check_goal", "display_path", "get_soil", "load_baseline_file", "load_config", "load_executor_config", "load_planner_config", "load_robot_config", "load_scene_config", "load_sensing_config", "load_soils", "load_trench_goal", "parse_config", "parse_yaml", "read_text_file"]
