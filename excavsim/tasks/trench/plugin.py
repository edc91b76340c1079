"""The trench task's plug-in: what the platform, the CLI, ``validate`` and the studies know of trenching.

Trenching (Singh 1995 §7.2, Fig. 107): the T3 digs a trench goal out of its soil box, or a hydraulic
excavator out of its pit, in the scan-plan-dig loop. Registered by one line of
:mod:`excavsim.loop.catalog`; everything else of the task is in this folder.
"""

from __future__ import annotations

import math
import pathlib
from typing import Any

from excavsim import config as c
from excavsim.config.kinds import ConfigKind, plain_kind
from excavsim.loop.plugin import EnvEntry, Metric, TaskPlugin
from excavsim.tasks.trench.spec import TrenchOptions

NAME = "trench"
DIG_ENV_ID = "excavsim/TrenchDig-v0"
JOINT_ENV_ID = "excavsim/TrenchJoint-v0"
JOINT_DIG_ENV_ID = "excavsim/TrenchJointDig-v0"
ENV_IDS = (DIG_ENV_ID, JOINT_ENV_ID, JOINT_DIG_ENV_ID)
"""The trench's environments (:mod:`excavsim.tasks.trench.envs`), as its plug-in registers them."""
JOINT_GOAL = "excavsim.tasks.trench.envs.joint:JointTrench"
"""The joint-level trench goal, by entry point (the ``goal`` keyword of the joint-level ids)."""
DIG_TASK = {"start": "near_soil", "max_time_s": 6.0, "scan_period_s": math.inf}
"""``excavsim/TrenchJointDig-v0``'s defaults: one dig from the bucket just above the soil, 600
steps on the T3, the map scanned once at reset (as the loop scans before each dig)."""
TRENCH_TASK = {"start": "near_soil", "max_time_s": 30.0, "scan_period_s": 1.0}
"""``excavsim/TrenchJoint-v0``'s defaults: the whole trench from just above the soil, 3,000 steps on
the T3, a scan every simulated second (the done rule reads the scan)."""


def _check_goal(path: pathlib.Path) -> str:
    from excavsim.tasks.trench.machines import machine_box, machine_scene
    from excavsim.tasks.trench.spec import T3

    # configs/trenches/<machine>/ holds another machine's goals, in its pit's coordinates
    machine = path.parent.name if path.parent.parent.name == "trenches" else T3
    c.check_goal(c.load_trench_goal(path), machine_scene(c.load_scene_config(), machine),
                 source=c.display_path(path), box=machine_box(machine) if machine != T3 else None)
    where = "the soil box" if machine == T3 else f"the {machine}'s pit"
    return f"TrenchGoal (inside {where}, below the initial soil of configs/scene.yaml)"


def _machine_model():
    from excavsim.tasks.trench.machines import MachineConfig

    return MachineConfig


def _check_machine(path: pathlib.Path) -> str:
    from excavsim.tasks.trench.machines import MachineConfig
    from excavsim.loop.scenario import merge

    cfg = c.load_config(path, MachineConfig)

    class Merged(c.StrictModel):
        planner: c.PlannerConfig
        executor: c.ExecutorConfig
        sensing: c.SensingConfig

    bases = {"planner": c.load_planner_config, "executor": c.load_executor_config, "sensing": c.load_sensing_config}
    c.parse_config({k: merge(load().model_dump(), getattr(cfg, k)) for k, load in bases.items()}, Merged,
                   source=c.display_path(path))
    return "MachineConfig (its overrides merged over configs/planner.yaml, executor.yaml and sensing.yaml)"


class Trench(TaskPlugin):
    """Trenching (Singh 1995 §7.2): dig a trench goal, scan after scan, with the planner's digs."""

    name = NAME
    title = "dig a trench goal with the T3 or a hydraulic excavator (Singh 1995 §7.2, Fig. 107)"
    machines = ("t3", "tb035", "excavator_25t")
    options = TrenchOptions
    budget = "digs"
    metrics = {
        "removed_fraction": Metric("higher", 0.05),
        "dug_l_per_dig": Metric("higher", 1.0, 0.10),
        "efficiency": Metric("higher", 0.05),
        "digs": Metric("lower", 1.0),
        "stalls": Metric("lower", 0.0),
        "overdig_max_cm": Metric("lower", 1.0),
        "underdig_max_cm": Metric("lower", 1.5),
        "underdig_rms_cm": Metric("lower", 0.5),
        "peak_wrist_pitch_nm": Metric("lower", 0.0, 0.10),
    }
    config_kinds = (
        plain_kind("robot", c.RobotConfig, "the T3's joints and servos (configs/robot.yaml)", stem=True),
        plain_kind("planner", c.PlannerConfig, "the trench planner (configs/planner.yaml)", stem=True),
        plain_kind("executor", c.ExecutorConfig, "the dig script (configs/executor.yaml)", stem=True),
        ConfigKind("goal", lambda: c.TrenchGoal, _check_goal, "a trench goal (configs/trenches/*.yaml)",
                   folders=("trenches",), subfolders=True),
        ConfigKind("machine", _machine_model, _check_machine,
                   "a trenching machine's overrides (configs/machines/*.yaml)", folders=("machines",)),
    )
    environments = (  # the joint-level ids: the platform's joint-level environment with the trench goal
        EnvEntry(DIG_ENV_ID, "excavsim.tasks.trench.envs.dig_env:TrenchDigEnv"),
        EnvEntry(JOINT_ENV_ID, "excavsim.envs.joint_env:JointEnv", {"goal": JOINT_GOAL, **TRENCH_TASK},
                 "excavsim.envs.batched:BatchedJointEnv"),
        EnvEntry(JOINT_DIG_ENV_ID, "excavsim.envs.joint_env:JointEnv", {"goal": JOINT_GOAL, **DIG_TASK},
                 "excavsim.envs.batched:BatchedJointEnv"),
    )
    dig_sources = {"planner": "excavsim.tasks.trench.digs:PlannedDigs",
                   "random": "excavsim.tasks.trench.digs:RandomFeasibleDigs",
                   "scripted": "excavsim.tasks.trench.digs:ScriptedDigs"}
    outputs = frozenset({"live", "save_maps", "timing"})

    def resolve(self, spec, *, robot_path=None, scene_path=None):
        from excavsim.tasks.trench.spec import TrenchResolved

        return TrenchResolved(spec, robot_path=robot_path, scene_path=scene_path)

    def episode(self, spec, resolved, *, progress=None, observer=None):
        from excavsim.tasks.trench.task import spec_episode

        return spec_episode(spec, resolved, progress=progress, observer=observer)

    def digs(self, spec):
        from excavsim.tasks.trench.task import spec_digs

        return spec_digs(spec)

    def as_mapping(self, field, value, data):
        if field != "goal":
            return None
        from excavsim.tasks.trench.spec import resolve_goal

        return resolve_goal(value, data.get("machine") or self.machines[0]).model_dump()

    def describe(self, spec, resolved) -> str:
        o = spec.options
        goal = o.goal if isinstance(o.goal, str) else (o.goal.name or "inline goal")
        by = "" if spec.machine_name == self.machines[0] else f" with the {spec.machine_name}"
        return (f"{goal} trench{by}, {spec.dig_budget} digs at most, soil {spec.soil or 'of the scene'}, "
                f"seed {spec.seed}")

    def summary(self, result) -> dict[str, Any]:
        from excavsim.tasks.trench.task import summary

        return summary(result)

    def dig_rows(self, result) -> list[dict[str, Any]]:
        from excavsim.tasks.trench.task import dig_rows

        return dig_rows(result)

    def progress_text(self, summary) -> str:
        from excavsim.loop.catalog import summary_number

        num = summary_number(summary)
        return (f"{num('digs')} digs, {num('dug_l_per_dig', fmt='.1f')} l/dig, {num('removed_fraction', 100)} % "
                f"removed, {num('stalls')} stalls")

    def format_run(self, result) -> str:
        from excavsim.handoff.episode import format_episode

        return format_episode(result)

    def recorder(self, path, *, live=None):
        from excavsim.tasks.trench.recording import episode_recorder

        return episode_recorder(path, live=live)

    def run_outputs(self, spec, resolved, *, save_maps=None, timing=False):
        from excavsim.handoff.episode import ObserverGroup

        observers, lines = [], []
        if save_maps:
            from excavsim.loop.episode import MapWriter

            observers.append(MapWriter(save_maps))
            lines.append(f"scanned maps saved in {save_maps} (map_NN.npz); plan on one with: "
                         f"excavsim plan --map {save_maps}/map_02.npz")
        timer = None
        if timing:
            from excavsim.tasks.trench.timing import Table7Timer

            timer = Table7Timer()
            observers.append(timer)

        def after(say) -> None:
            if timer is not None:
                say(timer.table())
            for line in lines:
                say(line)
        return (ObserverGroup(*observers) if observers else None), after

    def add_commands(self, sub) -> None:
        from excavsim.tasks.trench.commands import add_commands

        add_commands(sub)

    def warm_up(self, say) -> None:
        from excavsim.tasks.trench.warmup import warm_up

        warm_up(say)
