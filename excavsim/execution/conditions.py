"""Step conditions of parameterized scripts (Rowe 1997 §4.1-4.3): what a script reacts to.

A condition reads sensor-level data only (:class:`Sense`: joint angles and velocities, actuator
forces, the F/T reading, time and named events) plus what the engine knows of the sub-script it
belongs to (:class:`Context`: the current step, the time spent in it, the joint targets in force).
Build conditions with the helpers below; they are frozen data that print (:meth:`Cond.describe`).

:func:`held` conditions (a condition that has held for N ticks, or for a duration) remember earlier
ticks; the engine keeps their memory per step and clears it when a step starts. They count the
ticks on which they are evaluated: :func:`all_of` evaluates its conditions in order and stops at
the first that fails (and :func:`any_of` at the first that holds), so ``all_of(past(0.3),
held(force_above(120.0), ticks=3))`` only starts counting 0.3 s into the step, and a ``held``
after a condition that stops holding pauses (its count is kept) rather than starting again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from excavsim.errors import ConfigError, UsageError


@dataclasses.dataclass(frozen=True)
class Sense:
    """What a condition may look at on one tick (sensor-level only)."""

    time: float
    q: dict[str, float]
    qdot: dict[str, float]
    torque: dict[str, float]
    ft_force: np.ndarray  # the environment's force on the bucket, tip frame [N]
    events: frozenset[str] = frozenset()


@dataclasses.dataclass
class Context:
    """What the engine tells a condition about its sub-script.

    Attributes:
        step: the name of the sub-script's current step.
        step_time: seconds spent in it [s].
        targets: the joint targets in force [rad], by joint name.
        memory: the state of the :func:`held` conditions, by ``id`` of the condition.
    """

    step: str
    step_time: float
    targets: dict[str, float]
    memory: dict[int, float | None] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class Cond:
    """A step condition. Build with the helpers below (:func:`always`, :func:`joint_above`, ...)."""

    kind: str
    joint: str = ""
    value: float = 0.0
    children: tuple[Cond, ...] = ()
    joints: tuple[str, ...] = ()

    def holds(self, s: Sense, ctx: Context) -> bool:
        """Whether the condition holds on this tick."""
        k = self.kind
        if k == "always":
            return True
        if k == "joint_above":
            return s.q[self.joint] > self.value
        if k == "joint_below":
            return s.q[self.joint] < self.value
        if k == "after":
            return ctx.step_time >= self.value
        if k == "past":
            return ctx.step_time > self.value
        if k == "reached":
            t = ctx.targets.get(self.joint)
            return t is not None and abs(s.q[self.joint] - t) <= self.value
        if k == "settled":
            return all(j in ctx.targets and abs(s.q[j] - ctx.targets[j]) <= self.value for j in self.joints)
        if k == "force_above":
            return float(np.linalg.norm(s.ft_force)) > self.value
        if k == "force_below":
            return float(np.linalg.norm(s.ft_force)) < self.value
        if k == "event":
            return self.joint in s.events
        if k == "timed_out":
            return engine_event("timeout", ctx.step) in s.events
        if k == "held_ticks":
            n = ctx.memory.get(id(self)) or 0
            n = n + 1 if self.children[0].holds(s, ctx) else 0
            ctx.memory[id(self)] = n
            return n >= self.value
        if k == "held_s":
            if not self.children[0].holds(s, ctx):
                ctx.memory[id(self)] = None
                return False
            since = ctx.memory.get(id(self))
            if since is None:
                since = ctx.memory[id(self)] = s.time
            return s.time - since >= self.value
        if k == "all":
            return all(c.holds(s, ctx) for c in self.children)
        if k == "any":
            return any(c.holds(s, ctx) for c in self.children)
        raise ConfigError(f"unknown condition kind {k!r}; allowed: {', '.join(_KINDS)}")

    def describe(self) -> str:
        k = self.kind
        if k in ("all", "any"):
            word = " and " if k == "all" else " or "
            return f"({word.join(c.describe() for c in self.children)})"
        if k == "held_ticks":
            return f"{self.children[0].describe()} for {self.value:.0f} ticks"
        if k == "held_s":
            return f"{self.children[0].describe()} for {self.value:.4g} s"
        return {"always": "always", "joint_above": f"{self.joint} > {self.value:.4g}",
                "joint_below": f"{self.joint} < {self.value:.4g}", "after": f"after {self.value:.4g} s",
                "past": f"past {self.value:.4g} s", "reached": f"{self.joint} within {self.value:.3g} of target",
                "settled": f"{', '.join(self.joints)} within {self.value:.3g} of their targets",
                "force_above": f"|F| > {self.value:.4g} N", "force_below": f"|F| < {self.value:.4g} N",
                "event": f"event {self.joint}", "timed_out": "step timed out"}.get(k, k)


_KINDS = ("always", "joint_above", "joint_below", "after", "past", "reached", "settled", "force_above", "force_below",
          "event", "timed_out", "held_ticks", "held_s", "all", "any")


def always() -> Cond:
    return Cond("always")


def joint_above(joint: str, angle: float) -> Cond:
    return Cond("joint_above", joint, float(angle))


def joint_below(joint: str, angle: float) -> Cond:
    return Cond("joint_below", joint, float(angle))


def after(seconds: float) -> Cond:
    """Holds once the sub-script has spent ``seconds`` in its current step."""
    return Cond("after", value=float(seconds))


def past(seconds: float) -> Cond:
    """Holds once the sub-script has spent more than ``seconds`` in its current step (:func:`after`
    holds from the instant itself)."""
    return Cond("past", value=float(seconds))


def reached(joint: str, tol: float) -> Cond:
    """Holds when ``joint`` is within ``tol`` of its current command [rad]."""
    return Cond("reached", joint, float(tol))


def settled(joints: Sequence[str], tol: float) -> Cond:
    """Holds when every one of ``joints`` is within ``tol`` of its current command [rad]."""
    return Cond("settled", value=float(tol), joints=tuple(joints))


def force_above(newtons: float) -> Cond:
    """Holds when the F/T force's magnitude is above ``newtons``."""
    return Cond("force_above", value=float(newtons))


def force_below(newtons: float) -> Cond:
    """Holds when the F/T force's magnitude is below ``newtons``."""
    return Cond("force_below", value=float(newtons))


def event(name: str) -> Cond:
    return Cond("event", name)


def timed_out() -> Cond:
    """Holds once the sub-script's current step has run past its ``timeout_s`` (from the tick after)."""
    return Cond("timed_out")


def held(cond: Cond, *, ticks: int | None = None, seconds: float | None = None) -> Cond:
    """Holds when ``cond`` has held on ``ticks`` consecutive evaluations, or for ``seconds`` since the
    first evaluation it held on (give one of the two; see the module docstring for what counts)."""
    if (ticks is None) == (seconds is None):
        raise UsageError(f"held({cond.describe()}): give ticks or seconds, not {'both' if ticks else 'neither'}")
    if ticks is not None:
        return Cond("held_ticks", value=float(ticks), children=(cond,))
    return Cond("held_s", value=float(seconds), children=(cond,))


def all_of(*conds: Cond) -> Cond:
    """Holds when every one of ``conds`` holds (evaluated in order, up to the first that fails)."""
    return Cond("all", children=tuple(conds))


def any_of(*conds: Cond) -> Cond:
    """Holds when one of ``conds`` holds (evaluated in order, up to the first that holds)."""
    return Cond("any", children=tuple(conds))


def engine_event(kind: str, name: str) -> str:
    """The name of an event the engine raises itself (see :class:`~excavsim.execution.script.ScriptEngine`):
    ``kind`` is ``started`` (a step), ``path_end`` or ``path_done`` (a path command) or ``timeout`` (a step)."""
    return f"{kind}:{name}"


def started(step: str) -> Cond:
    """Holds once a sub-script has started step ``step``."""
    return event(engine_event("started", step))


def path_end(path: str) -> Cond:
    """Holds once the path command ``path`` has reached the end of its path."""
    return event(engine_event("path_end", path))


def path_done(path: str) -> Cond:
    """Holds once the path command ``path`` is done: at the end of its path with its joints settled."""
    return event(engine_event("path_done", path))
