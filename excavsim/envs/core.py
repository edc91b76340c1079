"""What every environment's core shares, free of any RL library and of any task.

A core steps one episode for an agent: :class:`DigLevelCore`, one step per dig (the platform's
:class:`~excavsim.loop.episode.Episode` of a task with the agent's dig in place of its planner's
choice), subclassed by each task that offers a dig-level environment in its own folder (its plug-in's
``environments``); :class:`~excavsim.envs.joint_core.JointCore` (in its own module), one step per control
period of any machine, with a goal that says what the episode is for. Each core has a Gymnasium face
(:mod:`~excavsim.envs.dig_env`, :mod:`~excavsim.envs.joint_env`) and a dm_env face (:mod:`~excavsim.envs.dm`).

:class:`Field` describes one observation entry for both faces; :func:`as_spec`, :func:`check_seed`,
:func:`check_weights` and :func:`check_vector` check what an environment is given.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from excavsim.config import parse_config
from excavsim.errors import EnvError
from excavsim.loop.digs import Choice
from excavsim.loop.scenario import EpisodeSpec, load_spec

MAX_SEED = 2**32 - 1  # EpisodeSpec.seed's bound
TERMINAL_ENDS = ("done", "no_dig", "diverged")
"""Episode ends that terminate (the task is done, nothing is left to dig, the world broke); the
dig budget and the wall-clock limit truncate."""


@dataclasses.dataclass(frozen=True)
class Field:
    """One entry of an observation: a float box (``low``/``high``) or, with ``n``, an integer in [0, n).

    Attributes:
        shape: the array's shape (``()`` for a scalar).
        dtype: numpy dtype name.
        low, high: bounds of a box (scalars, or arrays of ``shape``).
        n: number of values of a discrete entry (None for a box).
        doc: what it is, with units.
    """

    shape: tuple[int, ...]
    dtype: str
    low: Any = None
    high: Any = None
    n: int | None = None
    doc: str = ""


def as_spec(spec: EpisodeSpec | Mapping | str | pathlib.Path | None, task: str | None = None) -> EpisodeSpec:
    """An :class:`~excavsim.loop.scenario.EpisodeSpec` of task ``task`` from itself, a mapping of its fields
    (``task`` their default task), a YAML path, or None (the task's defaults). ``task`` None: the
    specification's own default task (:data:`~excavsim.loop.catalog.DEFAULT_TASK`), and a spec of any task.

    Raises:
        ConfigError: the mapping or file is not a valid specification.
        EnvError: the spec is of another task than ``task``, or not a specification at all.
    """
    given = {} if task is None else {"task": task}
    if spec is None:
        spec = EpisodeSpec(**given)
    elif isinstance(spec, Mapping):
        spec = parse_config({**given, **spec}, EpisodeSpec, source="the environment's spec")
    elif isinstance(spec, (str, pathlib.Path)):
        spec = load_spec(spec)
    if isinstance(spec, EpisodeSpec):
        if task is not None and spec.task != task:
            raise EnvError(f"this environment runs task {task}; the spec's task is {spec.task}")
        return spec
    raise EnvError(f"spec must be an EpisodeSpec, a mapping of its fields or a YAML path; given {type(spec).__name__}")


def check_seed(seed: Any) -> int:
    """``seed`` as an episode seed (an integer in [0, 2**32 - 1])."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise EnvError(f"seed must be an integer from 0 to {MAX_SEED}; given {seed!r}")
    return int(seed)


def check_weights(weights: Mapping[str, float] | None, defaults: Mapping[str, float], what: str) -> dict[str, float]:
    """Reward weights: ``defaults`` with ``weights`` over them, each a finite number >= 0."""
    out = dict(defaults)
    for key, value in (weights or {}).items():
        if key not in defaults:
            raise EnvError(f"unknown {what} reward weight {key!r}; allowed: {', '.join(defaults)}")
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = math.nan
        if not (math.isfinite(v) and v >= 0):
            raise EnvError(f"{what} reward weight {key} must be a finite number >= 0; given {value!r}")
        out[key] = v
    return out


def check_vector(action: Any, low: np.ndarray, high: np.ndarray, what: str) -> np.ndarray:
    """``action`` as a float64 vector of ``low``'s shape within [low, high] (1e-6 of slack for rounding)."""
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise EnvError(f"{what} must be {low.size} numbers; given {action!r}") from None
    if a.shape != low.shape:
        raise EnvError(f"{what} must have shape {low.shape}; given shape {a.shape}: {a!r}")
    ok = True
    for v, l_, h_ in zip(a.tolist(), low.tolist(), high.tolist()):  # scalars: a tenth of numpy's cost here
        slack = 1e-6 * max(1.0, h_ - l_)
        if not (l_ - slack <= v <= h_ + slack):
            ok = False
    if not ok:
        if not np.all(np.isfinite(a)):
            raise EnvError(f"{what} must be finite; given {a!r}")
        raise EnvError(f"{what} {a!r} is outside the action space (allowed: {low!r} to {high!r})")
    return a


class DigLevelCore:
    """What every dig-level environment's core does the same way: the platform's
    :class:`~excavsim.loop.episode.Episode` of its task, stepped one dig per agent action in the
    caller's thread (each task's dig-level core is a subclass in the task's folder).

    :meth:`reset` starts an episode and cycles it up to the first dig that needs the agent's action;
    :meth:`step` checks the action against the box ``action_low``..``action_high``, has the episode
    decide the agent's dig, digs it, and cycles on to the next decision or the end, which is
    ``terminated`` when the episode's end is one of :data:`TERMINAL_ENDS` and ``truncated``
    otherwise (the dig budget, the wall clock). A subclass supplies the task's side:
    :meth:`_start` (make the episode and reset it), :meth:`_advance` (cycle to the next decision:
    an object with ``result``, the episode's result once it ended), :meth:`_agent_choice_for` (the
    cycle's dig with the agent's action), :meth:`_dig` (dig the decided dig and set ``_last`` with
    its ``reward``), :meth:`_observation`, :meth:`_info` and :attr:`action_label`.
    """

    action_low: np.ndarray
    action_high: np.ndarray
    action_label = "the dig action"  # how check_vector names the action in its errors

    def _clear(self) -> None:
        """Forget the running episode's state (the subclass's too, when it extends this)."""
        self._pending = None  # the decision the agent is asked for, or the end
        self._last: dict[str, Any] | None = None  # the last dig and its reward (set by _dig)
        self._decided: dict[str, Any] | None = None  # how the agent's last action was dug
        self.result = None
        self.over = True  # no episode to step
        self.digs = 0

    def _start(self, seed: int) -> None:
        """Make ``self._episode`` and reset it with ``seed`` (with the task's pieces the core reads)."""
        raise NotImplementedError

    def _advance(self):
        raise NotImplementedError

    def _agent_choice_for(self, action: np.ndarray) -> Choice:
        raise NotImplementedError

    def _dig(self) -> None:
        raise NotImplementedError

    def reset(self, seed: int) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode with ``seed`` (abandoning any running one); its first observation and info."""
        if self._closed:
            raise EnvError("the environment is closed")
        seed = check_seed(seed)
        if self._episode is not None:
            self._episode.close()
        self._clear()
        try:
            self._start(seed)
            self.over = False  # an episode that ended before its first dig reports its end at the first step
            self._pending = decision = self._advance()
        except BaseException:
            self.over = True
            raise
        return self._observation(), self._info(decision, first=True)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Dig ``action``; (observation, reward, terminated, truncated, info).

        Raises:
            EnvError: the action is outside the space or not finite, or no episode is running
                (before the first reset, or after the episode ended).
        """
        if self.over:
            raise EnvError("the episode has ended (or never started): call reset() first")
        a = check_vector(action, self.action_low, self.action_high, self.action_label)
        self._last = self._decided = None
        if self._pending.result is not None:  # the episode ended before this step: nothing to dig
            decision, reward = self._pending, 0.0
        else:
            ep = self._episode
            try:
                ep.decide(self._agent_choice_for(a))
                if not ep.over:
                    self._dig()
                self._pending = decision = self._advance()
            except BaseException:
                self.over = True
                raise
            reward = self._last["reward"] if self._last is not None else 0.0
            self.digs += 1 if self._last is not None else 0
        terminated = truncated = False
        if decision.result is not None:
            self.result = decision.result
            terminated = decision.result.end in TERMINAL_ENDS
            truncated = not terminated
            self.over = True
        return self._observation(), float(reward), terminated, truncated, self._info(decision)

    def close(self) -> None:
        """Abandon the running episode and free the world; a closed core cannot be reset (closing twice is fine)."""
        if self._episode is not None:
            self._episode.close()
            self._episode = None
        self._clear()
        self._closed = True


