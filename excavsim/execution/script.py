"""Parameterized scripts (001_0de172b0d6b3614b.txt §4.1-4.3) and the engine that runs them.

A :class:`Script` is a set of sub-scripts, one per joint or joint group. Each sub-script is a list
of :class:`Step` s; a step is a *condition* and a *command*. A sub-script starts at its first step
and sends that step's command every tick; when the **next** step's condition holds it moves on
(Rowe & Stentz: "when the boom passes 14 deg, switch the swing command from 5 deg to 101 deg").
Conditions read sensor-level data only (:class:`Sense`: joint angles and velocities, actuator
forces, the F/T reading, time, and named events), and may watch any joint, which is how joints are
coupled. Commands are joint targets, or Cartesian tip targets and paths for the planar group that
the executor turns into joint targets through IK. The numbers are the parameters, filled for each
dig; scripts are frozen dataclasses that print and log as plain data (:meth:`Script.describe`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from excavsim.errors import ExcavsimError


@dataclasses.dataclass(frozen=True)
class Sense:
    """What a condition may look at on one tick (sensor-level only)."""

    time: float
    q: dict[str, float]
    qdot: dict[str, float]
    torque: dict[str, float]
    ft_force: np.ndarray  # the environment's force on the bucket, tip frame [N]
    events: frozenset[str] = frozenset()


@dataclasses.dataclass(frozen=True)
class Cond:
    """A step condition. Build with the helpers below (:func:`always`, :func:`joint_above`, ...)."""

    kind: str
    joint: str = ""
    value: float = 0.0
    children: tuple[Cond, ...] = ()

    def holds(self, s: Sense, step_time: float, targets: dict[str, float]) -> bool:
        """Whether the condition holds now (``step_time``: seconds in the sub-script's current step)."""
        k = self.kind
        if k == "always":
            return True
        if k == "joint_above":
            return s.q[self.joint] > self.value
        if k == "joint_below":
            return s.q[self.joint] < self.value
        if k == "after":
            return step_time >= self.value
        if k == "reached":
            t = targets.get(self.joint)
            return t is not None and abs(s.q[self.joint] - t) <= self.value
        if k == "force_above":
            return float(np.linalg.norm(s.ft_force)) > self.value
        if k == "event":
            return self.joint in s.events
        if k == "all":
            return all(c.holds(s, step_time, targets) for c in self.children)
        if k == "any":
            return any(c.holds(s, step_time, targets) for c in self.children)
        raise ExcavsimError(f"unknown condition kind {k!r}")

    def describe(self) -> str:
        k = self.kind
        if k in ("all", "any"):
            return f"({f' {k} '.join(c.describe() for c in self.children)})"
        return {"always": "always", "joint_above": f"{self.joint} > {self.value:.4g}",
                "joint_below": f"{self.joint} < {self.value:.4g}", "after": f"after {self.value:.4g} s",
                "reached": f"{self.joint} within {self.value:.3g} of target",
                "force_above": f"|F| > {self.value:.4g} N", "event": f"event {self.joint}"}.get(k, k)


def always() -> Cond:
    return Cond("always")


def joint_above(joint: str, angle: float) -> Cond:
    return Cond("joint_above", joint, float(angle))


def joint_below(joint: str, angle: float) -> Cond:
    return Cond("joint_below", joint, float(angle))


def after(seconds: float) -> Cond:
    """Holds once the sub-script has spent ``seconds`` in its current step."""
    return Cond("after", value=float(seconds))


def reached(joint: str, tol: float) -> Cond:
    """Holds when ``joint`` is within ``tol`` of its current command."""
    return Cond("reached", joint, float(tol))


def force_above(newtons: float) -> Cond:
    return Cond("force_above", value=float(newtons))


def event(name: str) -> Cond:
    return Cond("event", name)


def all_of(*conds: Cond) -> Cond:
    return Cond("all", children=tuple(conds))


def any_of(*conds: Cond) -> Cond:
    return Cond("any", children=tuple(conds))


@dataclasses.dataclass(frozen=True)
class Command:
    """A step command: ``targets`` for each joint of the sub-script, or a named Cartesian path that
    the executor resolves (``path``), or hold the current target (neither)."""

    targets: tuple[float, ...] = ()
    path: str = ""

    def describe(self) -> str:
        if self.path:
            return f"follow {self.path}"
        if self.targets:
            return "go to " + ", ".join(f"{np.degrees(t):.1f} deg" for t in self.targets)
        return "hold"


@dataclasses.dataclass(frozen=True)
class Step:
    name: str
    when: Cond
    command: Command


@dataclasses.dataclass(frozen=True)
class SubScript:
    """Steps for one joint or a joint group (``joints``; commands carry one target per joint)."""

    joints: tuple[str, ...]
    steps: tuple[Step, ...]


@dataclasses.dataclass(frozen=True)
class Script:
    name: str
    subscripts: tuple[SubScript, ...]

    def describe(self) -> str:
        """The script as text, one line per step (for logs)."""
        lines = [f"script {self.name}"]
        for sub in self.subscripts:
            lines.append(f"  [{', '.join(sub.joints)}]")
            for i, st in enumerate(sub.steps):
                lines.append(f"    {i + 1}. {st.name}: when {st.when.describe()} -> {st.command.describe()}")
        return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class Transition:
    """A sub-script moved to a new step."""

    time: float
    subscript: int
    step: int
    name: str


class ScriptEngine:
    """Runs a :class:`Script` tick by tick.

    Each :meth:`tick` advances every sub-script past the steps whose successors' conditions hold
    (at most one step per tick and sub-script, so a chain of conditions needs one tick each) and
    returns the commands now in force, per sub-script.
    """

    def __init__(self, script: Script):
        self.script = script
        for sub in script.subscripts:
            if not sub.steps:
                raise ExcavsimError(f"script {script.name!r}: a sub-script for {sub.joints} has no steps")
            for st in sub.steps:
                if st.command.targets and len(st.command.targets) != len(sub.joints):
                    raise ExcavsimError(f"script {script.name!r}, step {st.name!r}: {len(st.command.targets)} "
                                        f"targets for joints {sub.joints}")
        self.index = [0] * len(script.subscripts)
        self.entered = [None] * len(script.subscripts)  # time each sub-script entered its step
        self.targets: dict[str, float] = {}
        self.transitions: list[Transition] = []

    def current(self, i: int) -> Step:
        sub = self.script.subscripts[i]
        return sub.steps[self.index[i]]

    @property
    def finished(self) -> bool:
        """Every sub-script is on its last step."""
        return all(self.index[i] == len(s.steps) - 1 for i, s in enumerate(self.script.subscripts))

    def tick(self, sense: Sense) -> list[Command]:
        """Advance on this observation and return the command of each sub-script."""
        for i, sub in enumerate(self.script.subscripts):
            if self.entered[i] is None:
                self.entered[i] = sense.time
                self._apply(i)
                self.transitions.append(Transition(sense.time, i, 0, sub.steps[0].name))
                continue
            nxt = self.index[i] + 1
            if nxt < len(sub.steps) and sub.steps[nxt].when.holds(sense, sense.time - self.entered[i], self.targets):
                self.index[i] = nxt
                self.entered[i] = sense.time
                self._apply(i)
                self.transitions.append(Transition(sense.time, i, nxt, sub.steps[nxt].name))
        return [self.current(i).command for i in range(len(self.script.subscripts))]

    def _apply(self, i: int) -> None:
        cmd = self.current(i).command
        for j, t in zip(self.script.subscripts[i].joints, cmd.targets):
            self.targets[j] = t


def joint_steps(joint: str, names: Sequence[str], conds: Sequence[Cond], targets: Sequence[float]) -> SubScript:
    """A single-joint sub-script from parallel lists of step names, conditions and targets."""
    return SubScript((joint,), tuple(Step(n, c, Command((float(t),))) for n, c, t in zip(names, conds, targets)))
