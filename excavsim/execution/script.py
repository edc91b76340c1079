"""Parameterized scripts (Rowe 1997 §4.1-4.3) and the engine that runs them.

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
import math
from collections.abc import Sequence

import numba
import numpy as np

from excavsim.errors import ConfigError
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
            raise ConfigError(f"script {script.name!r}: step names repeat: {names}; give every step its own")
        for sub in script.subscripts:
            if not sub.steps:
                raise ConfigError(f"script {script.name!r}: a sub-script for {sub.joints} has no steps")
            for st in sub.steps:
                if st.command.targets and len(st.command.targets) != len(sub.joints):
                    raise ConfigError(f"script {script.name!r}, step {st.name!r}: {len(st.command.targets)} "
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


# -- the compiled engine ---------------------------------------------------------------------------
# Condition code: one row (op, a, b) and one value per instruction; a condition is a range of rows
# that leaves its result in a register. all_of / any_of jump to their end at the first child that
# fails / holds, so held conditions count exactly the evaluations the reference makes.
_ALWAYS, _NEVER, _JOINT_ABOVE, _JOINT_BELOW, _AFTER, _PAST, _REACHED, _SETTLED = range(8)
_FORCE_ABOVE, _FORCE_BELOW, _EVENT, _TIMED_OUT, _HELD_TICKS, _HELD_S, _JUMP_IF_FALSE, _JUMP_IF_TRUE = range(8, 16)
_LEAVES = {"always": _ALWAYS, "joint_above": _JOINT_ABOVE, "joint_below": _JOINT_BELOW, "after": _AFTER,
           "past": _PAST, "reached": _REACHED, "settled": _SETTLED, "force_above": _FORCE_ABOVE,
           "force_below": _FORCE_BELOW, "event": _EVENT, "timed_out": _TIMED_OUT}
# columns of the per-step table
(_S_WHEN0, _S_WHEN1, _S_ABORT0, _S_ABORT1, _S_ENDS0, _S_ENDS1, _S_WATCH0, _S_WATCHN, _S_PATH, _S_PEND, _S_PDONE,
 _S_STARTED, _S_TIMEOUT, _S_TG0, _S_TGN, _S_SUB) = range(16)
_STOP_KINDS = ("", "abort", "end", "timeout")


class CompiledEngine:
    """:class:`ScriptEngine` with its conditions compiled into instructions and its ticks in
    compiled code (numba): the same decisions tick by tick (a test runs both side by side, on the
    engine's own tests and on recorded digs), at a microsecond a tick instead of tens.

    The script becomes arrays once (:meth:`__init__`); each tick reads the joint angles as one
    array in ``joints`` order and the F/T force's magnitude. Besides :meth:`tick`, :meth:`report`
    and :meth:`end_tick` on a :class:`~excavsim.execution.conditions.Sense`, as the reference,
    :meth:`tick_arrays`, :meth:`report_arrays` and :meth:`end_tick_arrays` take the arrays directly
    (the executor's per-step path); :attr:`prog` and :attr:`state` are what compiled callers pass
    to :func:`engine_tick`, :func:`engine_report` and :func:`engine_end_tick`. Transitions,
    timeouts, events, targets and the stop read back as the reference's values.

    Args:
        script: the script.
        joints: the joint order of the angle arrays (default: the script's joints, in order of appearance).

    Raises:
        ExcavsimError: as :class:`ScriptEngine`, or a condition names a joint not in ``joints`` or a kind
            the engine does not know.
    """

    def __init__(self, script: Script, joints: Sequence[str] | None = None):
        ScriptEngine(script)  # the same validation
        self.script = script
        if joints is None:
            joints = list(dict.fromkeys(j for sub in script.subscripts for j in sub.joints))
        self.joints = tuple(joints)
        self._jid = {j: k for k, j in enumerate(self.joints)}
        self._eid: dict[str, int] = {}
        code: list[tuple[int, int, int]] = []
        vals: list[float] = []
        jl: list[int] = []
        slot_sub: list[int] = []
        slot_init: list[float] = []
        steps, tg, watch, subs = [], [], [], []
        self._steps = [st for sub in script.subscripts for st in sub.steps]
        self._step_sub: list[int] = []

        def joint(name: str) -> int:
            if name not in self._jid:
                raise ConfigError(f"script {script.name!r}: a condition reads joint {name!r}, which is not among "
                                  f"the engine's joints {self.joints}")
            return self._jid[name]

        def unit(cond: Cond | None, sub: int) -> tuple[int, int]:
            """Emit ``cond``'s code for sub-script ``sub`` (one memory per condition object, as the reference's
            per-use memory keyed by ``id``); returns its row range, (-1, -1) for none."""
            if cond is None:
                return -1, -1
            start, memo = len(code), {}

            def emit(c: Cond) -> None:
                if c.kind in ("all", "any"):
                    if not c.children:
                        code.append((_ALWAYS if c.kind == "all" else _NEVER, 0, 0))
                        vals.append(0.0)
                        return
                    jumps = []
                    for k, child in enumerate(c.children):
                        emit(child)
                        if k < len(c.children) - 1:
                            jumps.append(len(code))
                            code.append((_JUMP_IF_FALSE if c.kind == "all" else _JUMP_IF_TRUE, 0, -1))
                            vals.append(0.0)
                    for r in jumps:
                        code[r] = (code[r][0], 0, len(code))
                    return
                if c.kind in ("held_ticks", "held_s"):
                    emit(c.children[0])
                    if id(c) not in memo:
                        memo[id(c)] = len(slot_sub)
                        slot_sub.append(sub)
                        slot_init.append(0.0 if c.kind == "held_ticks" else math.nan)
                    code.append((_HELD_TICKS if c.kind == "held_ticks" else _HELD_S, memo[id(c)], 0))
                    vals.append(c.value)
                    return
                if c.kind not in _LEAVES:
                    raise ConfigError(f"unknown condition kind {c.kind!r}; allowed: {', '.join(_LEAVES)}, "
                                      "held_ticks, held_s, all, any")
                a = b = 0
                if c.kind in ("joint_above", "joint_below", "reached"):
                    a = joint(c.joint)
                elif c.kind == "settled":
                    a, b = len(jl), len(c.joints)
                    jl.extend(joint(j) for j in c.joints)
                elif c.kind == "event":
                    a = self._event(c.joint)
                code.append((_LEAVES[c.kind], a, b))
                vals.append(c.value)

            emit(cond)
            return start, len(code)

        for i, sub in enumerate(script.subscripts):
            subs.append((len(steps), len(sub.steps), len(jl), len(sub.joints)))
            jl.extend(joint(j) for j in sub.joints)
            for st in sub.steps:
                row = [0] * 16
                row[_S_WHEN0], row[_S_WHEN1] = unit(st.when, i)
                row[_S_ABORT0], row[_S_ABORT1] = unit(st.abort.when if st.abort else None, i)
                row[_S_ENDS0], row[_S_ENDS1] = unit(st.ends, i)
                row[_S_WATCH0], row[_S_WATCHN] = len(watch), len(st.watches)
                for w in st.watches:
                    w0, w1 = unit(w.when, i)
                    watch.append((w0, w1, self._event(w.event)))
                cmd = st.command
                row[_S_PATH] = int(bool(cmd.path))
                row[_S_PEND] = self._event(engine_event("path_end", cmd.path)) if cmd.path else -1
                row[_S_PDONE] = self._event(engine_event("path_done", cmd.path)) if cmd.path else -1
                row[_S_STARTED] = self._event(engine_event("started", st.name))
                row[_S_TIMEOUT] = self._event(engine_event("timeout", st.name))
                row[_S_TG0], row[_S_TGN] = len(tg), len(cmd.targets)
                tg.extend(float(t) for t in cmd.targets)
                row[_S_SUB] = i
                steps.append(row)
                self._step_sub.append(i)
        n_sub, n_steps, n_ev = len(script.subscripts), len(steps), len(self._eid)
        stepf = [(st.timeout_s if st.timeout_s is not None else math.nan, st.command.tol) for st in self._steps]
        limit = script.timeout_s if script.timeout_s is not None else math.nan
        self._events = list(self._eid)
        self.prog = (np.array(code, dtype=np.int64).reshape(-1, 3), np.array(vals, dtype=np.float64),
                     np.array(jl, dtype=np.int64), np.array(steps, dtype=np.int64).reshape(-1, 16),
                     np.array(stepf, dtype=np.float64).reshape(-1, 2), np.array(tg, dtype=np.float64),
                     np.array(watch, dtype=np.int64).reshape(-1, 3), np.array(subs, dtype=np.int64).reshape(-1, 4),
                     np.array(slot_sub, dtype=np.int64), np.array(slot_init, dtype=np.float64),
                     np.array([limit], dtype=np.float64))
        nj = len(self.joints)
        self.state = (
            np.zeros(n_sub, dtype=np.int64),  # 0 index
            np.full(n_sub, math.nan),  # 1 entered (NaN: not yet)
            np.zeros(n_sub, dtype=np.bool_),  # 2 at_end
            np.zeros(n_sub, dtype=np.bool_),  # 3 late
            np.zeros(nj),  # 4 targets
            np.zeros(nj, dtype=np.bool_),  # 5 has a target
            np.zeros(n_ev, dtype=np.bool_),  # 6 events
            np.zeros(n_ev, dtype=np.bool_),  # 7 the sense's own events (this tick)
            np.zeros(n_ev, dtype=np.bool_),  # 8 view (scratch)
            np.array(slot_init, dtype=np.float64),  # 9 held memory
            np.array([math.nan, math.nan]),  # 10 start time, stop time
            np.array([0, -1, 0, 0], dtype=np.int64),  # 11 stop kind, stop step, transitions, timeouts
            np.zeros((n_steps + 1, 2), dtype=np.int64),  # 12 transitions (sub, global step)
            np.zeros(n_steps + 1),  # 13 their times
            np.zeros((n_steps + 1, 2), dtype=np.int64),  # 14 timeouts (sub, global step)
            np.zeros(n_steps + 1),  # 15 their times
        )
        self.transitions: list[Transition] = []
        self.timeouts: list[Transition] = []
        self._stop: Stop | None = None

    def _event(self, name: str) -> int:
        return self._eid.setdefault(name, len(self._eid))

    # -- per-tick calls on arrays -----------------------------------------------------------------
    def tick_arrays(self, time: float, q: np.ndarray, force_norm: float) -> int:
        """:meth:`tick` on the joint angles ``q`` (in :attr:`joints` order) and ``|F|``; returns how many
        transitions it made (their :class:`Transition` s are appended to :attr:`transitions`)."""
        n = engine_tick(self.prog, self.state, time, q, force_norm)
        if n or self.state[11][0]:
            self._sync()
        return n

    def report_arrays(self, i: int, targets: np.ndarray, at_end: bool) -> None:
        """:meth:`report` with the targets as a float array."""
        engine_report(self.prog, self.state, i, targets, at_end)

    def end_tick_arrays(self, time: float, q: np.ndarray, force_norm: float) -> int:
        """:meth:`end_tick` on arrays; returns how many steps timed out on it (appended to :attr:`timeouts`)."""
        n = engine_end_tick(self.prog, self.state, time, q, force_norm)
        if n or self.state[11][0]:
            self._sync()
        return n

    # -- the reference's interface ----------------------------------------------------------------
    def tick(self, sense: Sense) -> list[Command]:
        """As :meth:`ScriptEngine.tick`."""
        q, fn = self._sense_arrays(sense)
        self.tick_arrays(sense.time, q, fn)
        return [st.command for st in self._currents()]

    def report(self, i: int, targets: Sequence[float], *, at_end: bool) -> None:
        """As :meth:`ScriptEngine.report`."""
        self.report_arrays(i, np.asarray(targets, dtype=np.float64), bool(at_end))

    def end_tick(self, sense: Sense) -> None:
        """As :meth:`ScriptEngine.end_tick`."""
        q, fn = self._sense_arrays(sense)
        self.end_tick_arrays(sense.time, q, fn)

    def _sense_arrays(self, sense: Sense) -> tuple[np.ndarray, float]:
        ext = self.state[7]
        ext[:] = False
        for e in sense.events:  # events no condition names cannot change a decision
            if e in self._eid:
                ext[self._eid[e]] = True
        q = np.array([sense.q[j] for j in self.joints], dtype=np.float64)
        return q, float(np.linalg.norm(sense.ft_force))

    def current(self, i: int) -> Step:
        """Sub-script ``i``'s current step."""
        return self.script.subscripts[i].steps[int(self.state[0][i])]

    def _currents(self) -> list[Step]:
        return [self.current(i) for i in range(len(self.script.subscripts))]

    @property
    def index(self) -> list[int]:
        return [int(k) for k in self.state[0]]

    @property
    def entered(self) -> list[float | None]:
        return [None if math.isnan(t) else float(t) for t in self.state[1]]

    @property
    def finished(self) -> bool:
        """Every sub-script is on its last step."""
        return all(self.index[i] == len(s.steps) - 1 for i, s in enumerate(self.script.subscripts))

    @property
    def targets(self) -> dict[str, float]:
        """The joint targets in force [rad], by joint name (the joints that have one)."""
        tgt, has = self.state[4], self.state[5]
        return {j: float(tgt[k]) for k, j in enumerate(self.joints) if has[k]}

    @property
    def events(self) -> set[str]:
        """Every event raised so far (by watches and by the engine)."""
        return {e for e, on in zip(self._events, self.state[6]) if on}

    @property
    def stop(self) -> Stop | None:
        """Why the script stopped, or None while it runs."""
        return self._stop

    @stop.setter
    def stop(self, value: Stop | None) -> None:  # the executor stops a script on its own step count
        self._stop = value
        self.state[11][0] = 3 if value is not None else 0

    def _sync(self) -> None:
        """Bring :attr:`transitions`, :attr:`timeouts` and :attr:`stop` up to the compiled state."""
        log = self.state[11]
        for n, out, rows, times in ((log[2], self.transitions, self.state[12], self.state[13]),
                                    (log[3], self.timeouts, self.state[14], self.state[15])):
            for k in range(len(out), int(n)):
                sub, g = int(rows[k, 0]), int(rows[k, 1])
                first = int(self.prog[7][sub, 0])
                out.append(Transition(float(times[k]), sub, g - first, self._steps[g].name))
        if log[0] and self._stop is None:
            kind, st = _STOP_KINDS[int(log[0])], self._steps[int(log[1])]
            self._stop = Stop(float(self.state[10][1]), kind, step=st.name,
                              abort=st.abort if kind == "abort" else None)


@numba.njit(cache=True)
def _holds(prog, state, i, r0, r1, view, time, q, force_norm):
    """Evaluate the condition code in rows [r0, r1) for sub-script ``i`` against the events ``view``."""
    code, vals, jl, steps = prog[0], prog[1], prog[2], prog[3]
    index, entered, tgt, has, mem = state[0], state[1], state[4], state[5], state[9]
    subs = prog[7]
    step_time = time - entered[i]
    r = False
    pc = r0
    while pc < r1:
        op, a, b, v = code[pc, 0], code[pc, 1], code[pc, 2], vals[pc]
        if op == _JUMP_IF_FALSE:
            if not r:
                pc = b
                continue
        elif op == _JUMP_IF_TRUE:
            if r:
                pc = b
                continue
        elif op == _ALWAYS:
            r = True
        elif op == _NEVER:
            r = False
        elif op == _JOINT_ABOVE:
            r = q[a] > v
        elif op == _JOINT_BELOW:
            r = q[a] < v
        elif op == _AFTER:
            r = step_time >= v
        elif op == _PAST:
            r = step_time > v
        elif op == _REACHED:
            r = has[a] and abs(q[a] - tgt[a]) <= v
        elif op == _SETTLED:
            r = True
            for k in range(a, a + b):
                j = jl[k]
                if not (has[j] and abs(q[j] - tgt[j]) <= v):
                    r = False
                    break
        elif op == _FORCE_ABOVE:
            r = force_norm > v
        elif op == _FORCE_BELOW:
            r = force_norm < v
        elif op == _EVENT:
            r = view[a]
        elif op == _TIMED_OUT:
            r = view[steps[subs[i, 0] + index[i], _S_TIMEOUT]]
        elif op == _HELD_TICKS:
            n = mem[a] + 1.0 if r else 0.0
            mem[a] = n
            r = n >= v
        elif op == _HELD_S:
            if not r:
                mem[a] = math.nan
            else:
                if math.isnan(mem[a]):
                    mem[a] = time
                r = time - mem[a] >= v
        pc += 1
    return r


@numba.njit(cache=True, inline="always")
def _log_step(rows, times, log, counter, i, g, time):
    """Append (sub-script ``i``, step ``g``, ``time``) to one of the engine's event logs: its ``rows``
    and ``times`` arrays, counted by ``log[counter]`` (transitions: state[12], state[13], log[2];
    timeouts: state[14], state[15], log[3])."""
    n = log[counter]
    rows[n, 0] = i
    rows[n, 1] = g
    times[n] = time
    log[counter] = n + 1


@numba.njit(cache=True)
def _enter(prog, state, i, step, time):
    """Sub-script ``i`` enters its step ``step``: memory cleared, targets set, ``started`` raised, logged."""
    steps, tg, jl, subs, slot_sub, slot_init = prog[3], prog[5], prog[2], prog[7], prog[8], prog[9]
    index, entered, at_end, late, tgt, has, events, mem, log = (state[0], state[1], state[2], state[3], state[4],
                                                                state[5], state[6], state[9], state[11])
    g = subs[i, 0] + step
    index[i] = step
    entered[i] = time
    for k in range(slot_sub.shape[0]):
        if slot_sub[k] == i:
            mem[k] = slot_init[k]
    at_end[i] = False
    late[i] = False
    for k in range(steps[g, _S_TGN]):
        j = jl[subs[i, 2] + k]
        tgt[j] = tg[steps[g, _S_TG0] + k]
        has[j] = True
    events[steps[g, _S_STARTED]] = True
    _log_step(state[12], state[13], log, 2, i, g, time)


@numba.njit(cache=True)
def _snapshot(state):
    """The events a condition sees: raised so far, and the sense's own."""
    view, events, ext = state[8], state[6], state[7]
    for k in range(view.shape[0]):
        view[k] = events[k] or ext[k]
    return view


@numba.njit(cache=True)
def engine_tick(prog, state, time, q, force_norm):
    """:meth:`ScriptEngine.tick` on a :class:`CompiledEngine`'s arrays; returns the number of transitions."""
    steps, subs = prog[3], prog[7]
    index, entered, log, times = state[0], state[1], state[11], state[10]
    if math.isnan(times[0]):
        times[0] = time
    before = log[2]
    view = _snapshot(state)
    n_sub = subs.shape[0]
    for i in range(n_sub):
        if math.isnan(entered[i]):
            _enter(prog, state, i, 0, time)
            continue
        nxt = index[i] + 1
        if nxt < subs[i, 1]:
            g = subs[i, 0] + nxt
            if _holds(prog, state, i, steps[g, _S_WHEN0], steps[g, _S_WHEN1], view, time, q, force_norm):
                _enter(prog, state, i, nxt, time)
    for i in range(n_sub):
        g = subs[i, 0] + index[i]
        if steps[g, _S_ABORT0] >= 0 and log[0] == 0 and _holds(prog, state, i, steps[g, _S_ABORT0],
                                                                steps[g, _S_ABORT1], view, time, q, force_norm):
            log[0] = 1
            log[1] = g
            times[1] = time
    return log[2] - before


@numba.njit(cache=True)
def engine_report(prog, state, i, targets, at_end):
    """:meth:`ScriptEngine.report` on a :class:`CompiledEngine`'s arrays."""
    steps, jl, subs = prog[3], prog[2], prog[7]
    tgt, has = state[4], state[5]
    for k in range(min(subs[i, 3], targets.shape[0])):
        j = jl[subs[i, 2] + k]
        tgt[j] = targets[k]
        has[j] = True
    state[2][i] = at_end
    pend = steps[subs[i, 0] + state[0][i], _S_PEND]
    if at_end and pend >= 0:
        state[6][pend] = True


@numba.njit(cache=True)
def engine_end_tick(prog, state, time, q, force_norm):
    """:meth:`ScriptEngine.end_tick` on a :class:`CompiledEngine`'s arrays; returns the number of timeouts."""
    steps, stepf, jl, watch, subs, limit = prog[3], prog[4], prog[2], prog[6], prog[7], prog[10][0]
    index, entered, at_end, late, tgt, has, events, log, times = (state[0], state[1], state[2], state[3], state[4],
                                                                  state[5], state[6], state[11], state[10])
    n_sub = subs.shape[0]
    before = log[3]
    for i in range(n_sub):
        g = subs[i, 0] + index[i]
        if steps[g, _S_PATH] and at_end[i]:
            done = True
            for k in range(subs[i, 3]):
                j = jl[subs[i, 2] + k]
                if not (has[j] and abs(q[j] - tgt[j]) <= stepf[g, 1]):
                    done = False
                    break
            if done:
                events[steps[g, _S_PDONE]] = True
    view = _snapshot(state)
    for i in range(n_sub):
        g = subs[i, 0] + index[i]
        for w in range(steps[g, _S_WATCH0], steps[g, _S_WATCH0] + steps[g, _S_WATCHN]):
            if not events[watch[w, 2]] and _holds(prog, state, i, watch[w, 0], watch[w, 1], view, time, q,
                                                  force_norm):
                events[watch[w, 2]] = True
    for i in range(n_sub):
        g = subs[i, 0] + index[i]
        if not math.isnan(stepf[g, 0]) and not late[i] and time - entered[i] > stepf[g, 0]:
            late[i] = True
            events[steps[g, _S_TIMEOUT]] = True
            _log_step(state[14], state[15], log, 3, i, g, time)
    view = _snapshot(state)
    for i in range(n_sub):
        g = subs[i, 0] + index[i]
        if steps[g, _S_ENDS0] >= 0 and log[0] == 0 and _holds(prog, state, i, steps[g, _S_ENDS0],
                                                               steps[g, _S_ENDS1], view, time, q, force_norm):
            log[0] = 2
            log[1] = g
            times[1] = time
    if log[0] == 0 and not math.isnan(limit) and time - times[0] > limit:
        log[0] = 3
        log[1] = subs[0, 0] + index[0]
        times[1] = time
    return log[3] - before
