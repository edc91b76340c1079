"""``excavsim validate``: load a configuration file of any kind with every check its use would make."""

from __future__ import annotations

from excavsim.errors import shorten

KINDS = ("robot", "scene", "soils", "sensing", "planner", "executor", "goal", "spec", "campaign",
         "experiment")  # the kinds of file validate_file checks


def validate_file(kind: str, path: str) -> str:
    """Load the ``kind`` file at ``path`` with every check its use would make; returns what it is.

    Goals are checked against configs/scene.yaml; specifications with their overrides and goal
    resolved; campaigns with every grid value; experiments with every run resolved.

    Raises:
        ConfigError: naming the file, the field and what is allowed.
    """
    from excavsim import config as c

    if kind not in KINDS:
        raise c.ConfigError(f"unknown kind of configuration file {shorten(repr(kind))}; allowed: {', '.join(KINDS)}")
    models = {"robot": c.RobotConfig, "scene": c.SceneConfig, "soils": c.SoilsFile, "sensing": c.SensingConfig,
              "planner": c.PlannerConfig, "executor": c.ExecutorConfig}
    if kind in models:
        return c.load_config(path, models[kind]).__class__.__name__
    if kind == "goal":
        c.check_goal(c.load_trench_goal(path), c.load_scene_config(), source=c.display_path(path))
        return "TrenchGoal"
    if kind == "campaign":
        from excavsim.loop.campaign import load_campaign

        return f"CampaignSpec ({len(load_campaign(path).grid)} grid keys, every value checked)"
    from excavsim.loop.scenario import ResolvedSpec, load_spec

    if kind == "spec":
        spec = load_spec(path)
        try:
            ResolvedSpec(spec)
        except c.ConfigError as exc:
            raise c.ConfigError(f"{c.display_path(path)}: {exc}") from None
        return "EpisodeSpec"
    from excavsim.loop.experiment import ExperimentSpec

    exp = c.load_config(path, ExperimentSpec)
    for run in exp.runs:
        try:
            ResolvedSpec(run)
        except c.ConfigError as exc:
            raise c.ConfigError(f"{c.display_path(path)}: run {shorten(run.name)}: {exc}") from None
    return f"ExperimentSpec ({len(exp.runs)} runs)"

