"""Parameterized scripts (001_0de172b0d6b3614b.txt §4.1-4.3) and the engine that runs them.

A :class:`Script` is a set of sub-scripts, one per joint or joint group. Each sub-script is a list
of :class:`Step` s; a step is a *condition* and a *command*. A sub-script starts at its first step
and sends that step's command every tick; when the **next** step's condition holds it moves on
(Rowe & Stentz: "when the boom passes 14 deg, switch the swing command from 5 deg to 101 deg").
Conditions (:mod:`excavsim.execution.conditions`) read sensor-level data only and may watch any
joint, which is how joints are coupled. Commands are joint targets, or named Cartesian paths for
the planar group that the executor follows at a speed and turns into joint targets through IK.
The numbers are the parameters, filled for each dig; scripts are frozen dataclasses that print and
log as plain data (:meth:`Script.describe`).

A step may also carry what happens while it runs: a ``timeout_s`` after which :func:`timed_out`
holds; :class:`Watch` es that raise a named event when their condition holds (the touch-down's
``contact``); an :class:`Abort` that stops the script with an outcome (the touch-down found
nothing); and an ending condition ``ends`` that stops it as finished. The script itself may have a
time limit.

One control tick runs in three parts:

1. :meth:`ScriptEngine.tick` (on the tick's observation): every sub-script moves on if its next
   step's condition holds (at most one step per tick and sub-script, so a chain of conditions needs
   one tick each); then the aborts of the current steps are checked. It returns the commands.
2. The executor turns commands into joint targets and tells the engine what it commanded
   (:meth:`ScriptEngine.report`: the targets of a path command and whether the path is at its end).
3. :meth:`ScriptEngine.end_tick` (same observation): path commands at their end with their joints
   settled are done; the watches of the current steps; the step timeouts; the endings; the time
   limit, in that order.

Events come from the sense, from watches, and from the engine itself
(:func:`~excavsim.execution.conditions.engine_event`: a step started, a path reached its end or is
done, a step timed out). Conditions in part 1 see the events raised before the tick began, so an
event raised on one tick moves a script on the next; those in part 3 also see the events raised
earlier in the same tick.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from excavsim.errors import ExcavsimError
from excavsim.execution.conditions import Cond, Context, Sense, engine_event


@dataclasses.dataclass(frozen=True)
class Command:
    """A step command: ``targets`` for each joint of the sub-script, or a named Cartesian path that
    the executor resolves (``path``, followed at ``speed`` [m/s]; done at its end once every joint
    is within ``tol`` [rad] of its target), or hold the current target (neither)."""

    targets: tuple[float, ...] = ()
    path: str = ""
    speed: float = 0.0
    tol: float = 0.0

    def describe(self) -> str:
        if self.path:
            return f"follow {self.path} at {self.speed:.3g} m/s (done at its end within {self.tol:.3g} rad)"
        if self.targets:
            return "go to " + ", ".join(f"{np.degrees(t):.1f} deg" for t in self.targets)
        return "hold"


@dataclasses.dataclass(frozen=True)
class Watch:
    """While its step runs, raise ``event`` on the first tick ``when`` holds."""

    event: str
    when: Cond


@dataclasses.dataclass(frozen=True)
class Abort:
    """While its step runs, stop the script with ``outcome`` when ``when`` holds; ``note`` says why."""

    outcome: str
    when: Cond
    note: str = ""


@dataclasses.dataclass(frozen=True)
class Step:
    """A step: moved to when ``when`` holds, sends ``command`` while it runs (see the module docstring
    for ``timeout_s`` [s], ``watches``, ``abort`` and ``ends``)."""

    name: str
    when: Cond
    command: Command
    timeout_s: float | None = None
    watches: tuple[Watch, ...] = ()
    abort: Abort | None = None
    ends: Cond | None = None

    def describe(self) -> list[str]:
        """The step as text: its trigger and command, then one line for each thing it watches."""
        lines = [f"{self.name}: when {self.when.describe()} -> {self.command.describe()}"]
        if self.timeout_s is not None:
            lines.append(f"times out after {self.timeout_s:.4g} s")
        lines += [f"raises {w.event} when {w.when.describe()}" for w in self.watches]
        if self.abort is not None:
            lines.append(f"aborts {self.abort.outcome!r} when {self.abort.when.describe()}")
        if self.ends is not None:
            lines.append(f"ends the script when {self.ends.describe()}")
        return lines


@dataclasses.dataclass(frozen=True)
class SubScript:
    """Steps for one joint or a joint group (``joints``; commands carry one target per joint)."""

    joints: tuple[str, ...]
    steps: tuple[Step, ...]


@dataclasses.dataclass(frozen=True)
class Script:
    """Sub-scripts run side by side; ``timeout_s``: the longest the whole script may run [s]."""

    name: str
    subscripts: tuple[SubScript, ...]
    timeout_s: float | None = None

    def describe(self) -> str:
        """The script as text, one line per step and per thing a step watches (for logs)."""
        limit = f" (stops after {self.timeout_s:.4g} s)" if self.timeout_s is not None else ""
        lines = [f"script {self.name}{limit}"]
        for sub in self.subscripts:
            lines.append(f"  [{', '.join(sub.joints)}]")
            for i, st in enumerate(sub.steps):
                first, *more = st.describe()
                lines.append(f"    {i + 1}. {first}")
                lines += [f"         {m}" for m in more]
        return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class Transition:
    """A sub-script moved to a new step (or, in :attr:`ScriptEngine.timeouts`, a step timed out)."""

    time: float
    subscript: int
    step: int
    name: str


@dataclasses.dataclass(frozen=True)
class Stop:
    """Why the script stopped.

    Attributes:
        time: when [s].
        kind: "abort" (a step's :class:`Abort`), "end" (a step's ``ends``) or "timeout" (the
            script's ``timeout_s``).
        step: the step whose abort or ending held; for a timeout, the first sub-script's step.
        abort: the abort, for kind "abort".
    """

    time: float
    kind: str
    step: str
    abort: Abort | None = None


class ScriptEngine:
    """Runs a :class:`Script` tick by tick (see the module docstring for the order within a tick).

    Attributes:
        targets: the joint targets in force [rad], by joint name.
        events: every event raised so far (by watches and by the engine).
        transitions: every step change, in order.
        timeouts: every step that ran past its ``timeout_s``.
        stop: why the script stopped, or None while it runs.
    """

    def __init__(self, script: Script):
        self.script = script
        names = [st.name for sub in script.subscripts for st in sub.steps]
        if len(set(names)) != len(names):  # events and records name steps
            raise ExcavsimError(f"script {script.name!r}: step names repeat: {names}; give every step its own")
        for sub in script.subscripts:
            if not sub.steps:
                raise ExcavsimError(f"script {script.name!r}: a sub-script for {sub.joints} has no steps")
            for st in sub.steps:
                if st.command.targets and len(st.command.targets) != len(sub.joints):
                    raise ExcavsimError(f"script {script.name!r}, step {st.name!r}: {len(st.command.targets)} "
                                        f"targets for joints {sub.joints}")
        n = len(script.subscripts)
        self.index = [0] * n
        self.entered: list[float | None] = [None] * n  # time each sub-script entered its step
        self.targets: dict[str, float] = {}
        self.events: set[str] = set()
        self.transitions: list[Transition] = []
        self.timeouts: list[Transition] = []
        self.stop: Stop | None = None
        self._start: float | None = None
        self._memory: list[dict[str, dict]] = [{} for _ in range(n)]  # stateful conditions, per step and use
        self._at_end = [False] * n  # the path command has reached its end (as last reported)
        self._late = [False] * n
        self._current = [sub.steps[0] for sub in script.subscripts]

    def current(self, i: int) -> Step:
        """Sub-script ``i``'s current step."""
        return self._current[i]

    @property
    def finished(self) -> bool:
        """Every sub-script is on its last step."""
        return all(self.index[i] == len(s.steps) - 1 for i, s in enumerate(self.script.subscripts))

    def tick(self, sense: Sense) -> list[Command]:
        """Advance on this observation, check the aborts, and return the command of each sub-script."""
        if self._start is None:
            self._start = sense.time
        view = self._view(sense)
        for i, sub in enumerate(self.script.subscripts):
            if self.entered[i] is None:
                self._enter(i, 0, sense.time)
                continue
            nxt = self.index[i] + 1
            if nxt < len(sub.steps) and self._holds(i, "when", sub.steps[nxt].when, view):
                self._enter(i, nxt, sense.time)
        for i, st in enumerate(self._current):
            if st.abort is not None and self.stop is None and self._holds(i, "abort", st.abort.when, view):
                self.stop = Stop(sense.time, "abort", abort=st.abort, step=st.name)
        return [st.command for st in self._current]

    def report(self, i: int, targets: Sequence[float], *, at_end: bool) -> None:
        """What the executor commanded for sub-script ``i``'s path command this tick: the joint
        ``targets`` [rad] (one per joint of the sub-script) and whether the path is at its end."""
        for j, t in zip(self.script.subscripts[i].joints, targets):
            self.targets[j] = t
        self._at_end[i] = at_end
        if at_end:
            self.events.add(engine_event("path_end", self.current(i).command.path))

    def end_tick(self, sense: Sense) -> None:
        """Finish the tick on the same observation: paths done, watches, timeouts, endings, time limit."""
        steps = list(enumerate(self._current))
        for i, st in steps:
            cmd = st.command
            if cmd.path and self._at_end[i] and all(j in self.targets and abs(sense.q[j] - self.targets[j]) <= cmd.tol
                                                     for j in self.script.subscripts[i].joints):
                self.events.add(engine_event("path_done", cmd.path))
        view, raised = self._view(sense), len(self.events)
        for i, st in steps:
            for k, w in enumerate(st.watches):
                if w.event not in self.events and self._holds(i, f"watch {k}", w.when, view):
                    self.events.add(w.event)
        for i, st in steps:
            if st.timeout_s is not None and not self._late[i] and sense.time - self.entered[i] > st.timeout_s:
                self._late[i] = True
                self.events.add(engine_event("timeout", st.name))
                self.timeouts.append(Transition(sense.time, i, self.index[i], st.name))
        if len(self.events) != raised:
            view = self._view(sense)
        for i, st in steps:
            if st.ends is not None and self.stop is None and self._holds(i, "ends", st.ends, view):
                self.stop = Stop(sense.time, "end", step=st.name)
        limit = self.script.timeout_s
        if self.stop is None and limit is not None and sense.time - self._start > limit:
            self.stop = Stop(sense.time, "timeout", step=self._current[0].name)

    def _view(self, sense: Sense) -> Sense:
        """``sense`` with the events raised so far."""
        if not self.events:
            return sense
        return Sense(sense.time, sense.q, sense.qdot, sense.torque, sense.ft_force, sense.events | self.events)

    def _holds(self, i: int, use: str, cond: Cond, sense: Sense) -> bool:
        ctx = Context(self._current[i].name, sense.time - self.entered[i], self.targets,
                      self._memory[i].setdefault(use, {}))
        return cond.holds(sense, ctx)

    def _enter(self, i: int, step: int, time: float) -> None:
        self.index[i] = step
        self._current[i] = self.script.subscripts[i].steps[step]
        self.entered[i] = time
        self._memory[i] = {}
        self._at_end[i] = False
        self._late[i] = False
        st = self.current(i)
        for j, t in zip(self.script.subscripts[i].joints, st.command.targets):
            self.targets[j] = t
        self.events.add(engine_event("started", st.name))
        self.transitions.append(Transition(time, i, step, st.name))


def joint_steps(joint: str, names: Sequence[str], conds: Sequence[Cond], targets: Sequence[float]) -> SubScript:
    """A single-joint sub-script from parallel lists of step names, conditions and targets."""
    return SubScript((joint,), tuple(Step(n, c, Command((float(t),))) for n, c, t in zip(names, conds, targets)))
