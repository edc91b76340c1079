"""The pile-loading task's plug-in: the front loader or the front shovel loads from a pile in MuJoCo.

Singh 1995 §7.2.1: dig after dig from a pile in a lane one bucket wide, each planned on the scanned
map by the loading planner and delivered at the truck's place. Registered by one line of
:mod:`excavsim.loop.catalog`; the rest of the task is in this folder (the 2-D study of Figs. 108-112
too: ``excavsim load``).
"""

from __future__ import annotations

import pathlib
from typing import Any

from pydantic import Field

from excavsim.config import StrictModel
from excavsim.config.kinds import ConfigKind, plain_kind
from excavsim.tasks.pile_loading.config_planar import LoadingConfig
from excavsim.tasks.pile_loading.config import LoadingCampaign, LoadingMujocoConfig
from excavsim.loop.plugin import EnvEntry, Metric, TaskPlugin

NAME = "pile_loading"
LOAD_DIG_ENV_ID = "excavsim/LoadDig-v0"
"""The task's environment (:mod:`excavsim.tasks.pile_loading.envs`), as its plug-in registers it."""


class PileLoadingOptions(StrictModel):
    """The pile-loading task's fields of an episode specification."""

    pile_loading: dict[str, Any] = Field(default_factory=dict,
                                         description="overrides of configs/pile_loading.yaml (the pile, the "
                                                     "scanner, the map, the dig script)")


def _check_campaign(path: pathlib.Path) -> str:
    from excavsim.config import ConfigError, display_path
    from excavsim.tasks.pile_loading.config import load_loading_campaign, load_loading_mujoco_config

    spec = load_loading_campaign(path)
    if spec.mujoco_config is not None:  # read as `excavsim load --campaign` reads it: relative to the working directory
        try:
            load_loading_mujoco_config(spec.mujoco_config)
        except ConfigError as exc:
            raise ConfigError(f"{display_path(path)}: mujoco_config: {exc}") from None
    n, s = len(spec.machines), len(spec.seeds)
    return f"LoadingCampaign ({n} machine{'s' * (n != 1)} x {s} seed{'s' * (s != 1)})"


class PileLoading(TaskPlugin):
    """Loading from a pile in MuJoCo (Singh 1995 §7.2.1) with the front loader or the front shovel."""

    name = NAME
    title = "load from a pile with the front loader or the front shovel in MuJoCo (Singh 1995 §7.2.1)"
    machines = ("loader", "shovel")
    options = PileLoadingOptions
    renamed_fields = {"loading": "pile_loading"}
    budget = "digs"
    metrics = {
        "removed_fraction": Metric("higher", 0.05),
        "digs": Metric("lower", 1.0),
        "failed_digs": Metric("lower", 0.0),        # digs that delivered under a tenth of the heaped capacity
        "delivered_l": Metric("higher", 10.0, 0.10),  # soil poured at the truck [l]
        "spilled_l": Metric("lower", 20.0, 0.25),     # soil that left the lane otherwise [l]
        "efficiency": Metric("higher", 0.05),
    }
    columns = (("delivered_l", "deliv. l"), ("spilled_l", "spilled l"))
    config_kinds = (
        plain_kind("pile_loading_planar", LoadingConfig, "the 2-D loading simulation (configs/pile_loading_planar.yaml)",
                   stem=True),
        plain_kind("pile_loading", LoadingMujocoConfig, "loading from a pile in MuJoCo (configs/pile_loading.yaml)",
                   stem=True),
        ConfigKind("pile_loading_campaign", lambda: LoadingCampaign, _check_campaign,
                   "a campaign of MuJoCo loading episodes (configs/campaigns/pile_loading_machines.yaml)",
                   folders=("campaigns",)),
    )
    environments = (EnvEntry(LOAD_DIG_ENV_ID, "excavsim.tasks.pile_loading.envs.dig_env:LoadDigEnv"),)

    outputs = frozenset({"live"})

    def resolve(self, spec, *, robot_path=None, scene_path=None) -> LoadingMujocoConfig:
        from excavsim.tasks.pile_loading.config import load_loading_mujoco_config
        from excavsim.loop.scenario import override

        super().resolve(spec, robot_path=robot_path, scene_path=scene_path)
        cfg = override(load_loading_mujoco_config(), spec.options.pile_loading, LoadingMujocoConfig,
                       f"{spec.name}: pile_loading")
        return cfg.model_copy(update={"soil": spec.soil}) if spec.soil else cfg

    def episode(self, spec, resolved, *, progress=None, observer=None):
        from excavsim.loop.episode import Episode
        from excavsim.tasks.pile_loading.task import LoadTask

        return Episode(LoadTask(spec.machine_name, cfg=resolved), dig_budget=spec.dig_budget, progress=progress,
                       observer=observer)

    def summary(self, result) -> dict[str, Any]:
        from excavsim.tasks.pile_loading.task import summary

        return summary(result)

    def dig_rows(self, result) -> list[dict[str, Any]]:
        from excavsim.tasks.pile_loading.task import dig_rows

        return dig_rows(result)

    def progress_text(self, summary) -> str:
        from excavsim.loop.catalog import summary_number

        num = summary_number(summary)
        return (f"{num('digs')} digs, {num('removed_fraction', 100)} % of the pile removed, {num('delivered_l')} l "
                "delivered")

    def format_run(self, result) -> str:
        from excavsim.tasks.pile_loading.task import format_run

        return format_run(result)

    def recorder(self, path, *, live=None):
        from excavsim.tasks.pile_loading.task import episode_recorder

        return episode_recorder(path, live=live)

    def add_commands(self, sub) -> None:
        from excavsim.tasks.pile_loading.commands import add_commands

        add_commands(sub, self.machines)
