"""The exception tree of excavsim.errors: its shape, the old homes of the moved classes, and the
command's handling of every kind (one line on stderr, exit status 2)."""

from __future__ import annotations

import numpy as np
import pytest

import excavsim
from excavsim import errors
from excavsim.cli import main
from excavsim.errors import (ConfigError, DataFileError, DependencyError, Diverged, EnvError, ExcavsimError, GoalError,
                             ModelError, OutOfTime, SoilModelError, UsageError, WedgeError, WorldError)

PARENT = {ConfigError: ExcavsimError, GoalError: ConfigError, UsageError: ExcavsimError, ModelError: ExcavsimError,
          WorldError: ExcavsimError, Diverged: WorldError, OutOfTime: WorldError, EnvError: ExcavsimError,
          SoilModelError: ExcavsimError, WedgeError: SoilModelError, DataFileError: ExcavsimError,
          DependencyError: ExcavsimError}


def test_the_tree_has_one_root_and_each_kind_its_parent():
    kinds = {v for v in vars(errors).values() if isinstance(v, type) and issubclass(v, Exception)}
    assert kinds == {ExcavsimError, *PARENT}  # nothing left out of the table, nothing extra
    for kind, parent in PARENT.items():
        assert kind.__bases__[0] is parent, kind
        assert kind.__doc__ and len(kind.__doc__) > 30, kind
    assert ExcavsimError.__bases__ == (Exception,)
    # the kinds that were ValueErrors before the tree stay so, for callers that catch ValueError
    assert issubclass(EnvError, ValueError) and issubclass(SoilModelError, ValueError)
    assert issubclass(WedgeError, ValueError)
    assert not issubclass(ConfigError, WorldError) and not issubclass(DataFileError, ConfigError)


def test_the_kinds_are_exported_and_the_moved_ones_keep_their_old_names():
    for kind in (ExcavsimError, *PARENT):
        assert getattr(excavsim, kind.__name__) is kind
    from excavsim.envs import EnvError as env_error
    from excavsim.handoff.observation import Diverged as diverged
    from excavsim.handoff.observation import OutOfTime as out_of_time
    from excavsim.mechanics.wedge import WedgeError as wedge_error

    assert (env_error, diverged, out_of_time, wedge_error) == (EnvError, Diverged, OutOfTime, WedgeError)


def test_library_calls_raise_their_kind():
    from excavsim.config import TrenchGoal, check_goal, load_scene_config
    from excavsim.handoff.maps import ElevationMap
    from excavsim.learning.predictors import make_model
    from excavsim.mechanics.earth_pressure import coulomb_passive_coefficient
    from excavsim.world.settle import settle

    goal = TrenchGoal(name="far", near_x_m=3.7, far_x_m=3.9, depth_m=0.2, surface_z_m=0.5)
    with pytest.raises(GoalError, match="outside the soil box"):
        check_goal(goal, load_scene_config())
    with pytest.raises(ConfigError, match="unknown learning method 'nope'"):
        make_model("nope")
    with pytest.raises(SoilModelError, match="phi > 0"):
        coulomb_passive_coefficient(np.array([-0.1]), np.array([0.0]))
    with pytest.raises(SoilModelError, match="repose_rad"):
        settle(np.zeros((3, 3)), 0.05, 2.0)
    with pytest.raises(DataFileError, match="no-such.npz"):
        ElevationMap.load("no-such.npz")


def _one_error_line(capsys) -> str:
    """The one message on stderr: its first line says ``excavsim: error:``; a configuration error
    lists every problem under it, indented."""
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert lines[0].startswith("excavsim: error: "), err
    assert all(line.startswith("  ") for line in lines[1:]), err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("kind", [ExcavsimError, *PARENT])
def test_the_command_prints_every_kind_on_one_line_and_exits_2(kind, monkeypatch, capsys):
    import excavsim.validate

    def fail(*_args, **_kwargs):
        raise kind(f"a {kind.__name__} for the test\nsecond line of it")

    monkeypatch.setattr(excavsim.validate, "validate_file", fail)
    assert main(["validate", "robot", "any.yaml"]) == 2
    err = capsys.readouterr().err  # validate names the file before the message
    assert err == f"excavsim: error: any.yaml: a {kind.__name__} for the test\nsecond line of it\n"


def test_real_errors_of_four_kinds_exit_2_with_one_message(tmp_path, capsys):
    bad = tmp_path / "robot.yaml"
    bad.write_text("joints: 3\n")
    assert main(["validate", "robot", str(bad)]) == 2  # ConfigError
    assert "robot.yaml" in _one_error_line(capsys)
    goal = tmp_path / "far.yaml"
    goal.write_text("name: far\nnear_x_m: 3.7\nfar_x_m: 3.9\ndepth_m: 0.2\nsurface_z_m: 0.5\n")
    assert main(["validate", "goal", str(goal)]) == 2  # GoalError
    assert "outside the soil box" in _one_error_line(capsys)
    assert main(["regress", "--update", "--against", "HEAD"]) == 2  # UsageError
    assert "give only one of them" in _one_error_line(capsys)
    garbled = tmp_path / "map.npz"
    garbled.write_bytes(b"PK\x03\x04 not a zip archive")
    assert main(["plan", "--map", str(garbled), "--no-figures"]) == 2  # DataFileError
    assert "map.npz: not an elevation map" in _one_error_line(capsys)
