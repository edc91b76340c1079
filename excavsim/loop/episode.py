"""The platform's episode: a task's dig-scan-plan loop, reset and advanced one cycle at a time (§7.2, Fig. 107).

:class:`Episode` is the one loop of excavsim, for every task of :mod:`~excavsim.loop.catalog`. Each
cycle the task parks its machine, scans the terrain into an elevation map and reads it (its done
test), a dig source chooses one dig on the map (:class:`~excavsim.loop.digs.DigSource`), the task
executes it and lets the soil settle. The episode ends when the task is done, when the source has
no dig (``no_dig``), when the dig budget is spent (``budget``), when the simulation diverged
(``diverged``: the world's watchdog saw a MuJoCo warning, a reset or a non-finite state) or when the
task's wall-clock limit has passed (``timeout``).

:class:`Task` is what a task's episode supplies (its world, map reading, dig source, execution, done test
and metrics); each task's lives in its folder of :mod:`excavsim.tasks`, made by its plug-in
(:meth:`~excavsim.loop.plugin.TaskPlugin.episode`). :class:`Episode` is the episode as an object one
can reset and advance one cycle (or one phase of a cycle) at a time; the dig-level environments
(:mod:`excavsim.envs`) step one with the agent's digs. An
:class:`~excavsim.handoff.episode.EpisodeObserver` handed in by the caller (the Rerun recorder, the
online learner, :class:`MapWriter`) sees every scan, plan, control step and dig.
"""

from __future__ import annotations

import contextlib
import pathlib
import time
from collections.abc import Callable
from typing import Any, Protocol

from excavsim.errors import ExcavsimError
from excavsim.handoff.episode import EpisodeObserver
from excavsim.handoff.maps import ElevationMap
from excavsim.handoff.observation import Diverged, OutOfTime
from excavsim.loop.digs import Choice


class EpisodeError(ExcavsimError):
    """An episode's phase called out of order: before :meth:`Episode.reset`, after its end, or
    skipping a phase (look, decide, dig)."""


class MapWriter(EpisodeObserver):
    """Saves every scanned elevation map as ``DIR/map_<cycle>.npz`` (for ``excavsim plan --map``)."""

    def __init__(self, directory: str | pathlib.Path):
        self.directory = pathlib.Path(directory)
        self.paths: list[pathlib.Path] = []

    def started(self, sim, rig, goal_mask, goal_z):
        self.directory.mkdir(parents=True, exist_ok=True)

    def scanned(self, index, emap, accuracy):
        path = self.directory / f"map_{index:02d}.npz"
        emap.save(path)
        self.paths.append(path)



class Task(Protocol):
    """What a task supplies to the platform's :class:`Episode`: its world and pieces, its map reading,
    its dig source, its execution of a dig, its done test and its metrics. The episode does the rest,
    written once for every task: the order of the phases, the observers' hooks, the dig budget,
    the wall clock and its limit, the world's failures while parking, and the end.

    Each hook's arguments are the task's own (a trench's :class:`~excavsim.handoff.dig.Dig` and
    :class:`~excavsim.handoff.dig.ExecutionRecord`, a loading dig's path and its record); an observer of
    a task knows them (the task's recorder is made by its plug-in).

    Attributes:
        wall_limit_s: the episode's wall-clock limit [s] (``math.inf``: none), known after :meth:`reset`.
        final_scan: whether the dig budget's last dig is followed by a scan that checks it (a
            trench's done test); otherwise the episode ends right after it.
    """

    wall_limit_s: float
    final_scan: bool

    def reset(self, seed: int, world: Any = None, digs: Any = None) -> tuple:
        """Build the world (unless given) and the task's pieces for an episode of ``seed``; the
        arguments of the observers' ``started`` hook (the world first)."""

    def budget_reason(self, budget: int) -> str:
        """Why the episode ended when its ``budget`` of digs was spent."""

    def park(self) -> None:
        """The moves before a scan (may raise ``Diverged`` or ``OutOfTime``: the episode ends)."""

    def scan(self) -> tuple[ElevationMap, Any]:
        """Scan the terrain into a map: the map and the ``scanned`` hook's detail."""

    def assess(self, index: int, scanned: ElevationMap, say: Callable[[str], None]
               ) -> tuple[Any, tuple[str, str] | None]:
        """The map the dig source believes, and (end, reason) when the map ends the episode (done)."""

    def choose(self, emap: Any) -> Choice:
        """The cycle's dig on the believed map (a :class:`~excavsim.loop.digs.Choice`; no dig ends the episode)."""

    def execute(self, index: int, choice: Choice) -> tuple[tuple | None, tuple[str, str] | None]:
        """Execute dig ``index`` and let the soil settle: the ``dug`` hook's arguments after the index,
        or None and (end, reason) when the world failed before there was a dig to record."""

    def after(self, index: int, choice: Choice, dug: tuple, say: Callable[[str], None]) -> tuple[str, str] | None:
        """After the ``dug`` hook: report, learn, and (end, reason) when the dig ended the episode."""

    def result(self, end: str, reason: str, wall_s: float) -> Any:
        """The episode's result (the ``finished`` hook's argument)."""



class Episode:
    """An episode of a :class:`Task` as an object: :meth:`reset` it, then
    advance it one cycle at a time.

    A cycle (:meth:`step`) is three phases, which a caller that decides the dig itself (the
    environments of :mod:`excavsim.envs`) may call one by one:

    * :meth:`look`: the task parks, scans the terrain into a map (the ``scanned`` hook) and reads
      it (the dig source's belief; the done test); the wall clock's and the dig budget's limits;
    * :meth:`decide`: the cycle's dig, from the task's dig source or given by the caller (the
      ``planned`` hook); no dig ends the episode (``no_dig``);
    * :meth:`dig`: the task executes the dig and lets the soil settle (the ``dug`` hook), then
      reports and learns.

    The episode ends (:attr:`over`; :attr:`result` set, the ``finished`` hook called) when a phase
    meets a stopping rule; an error in a phase ends it too (``finished`` with None), and
    :meth:`close` abandons a running one the same way. The wall clock runs only inside the phases,
    so the time a caller spends between them (an agent thinking) counts neither towards the task's
    wall-clock limit nor towards the result's wall time.

    Args:
        task: the task's episode part (a :class:`Task`, made by the task's plug-in).
        dig_budget: the most digs.
        progress: called with a line of text per scan and per dig.
        observer: sees every episode (see :class:`~excavsim.handoff.episode.EpisodeObserver`).
    """

    def __init__(self, task: Task, *, dig_budget: int = 20, progress: Callable[[str], None] | None = None,
                 observer: EpisodeObserver | None = None):
        self.task = task
        self.dig_budget = int(dig_budget)
        self.say = progress or (lambda _s: None)
        self.observer = observer or _Unobserved()
        self.sim = None  # the world
        self.over = True  # no episode runs before reset
        self.result = None
        self._phase = "none"
        self._hooked = False

    # -- the episode ---------------------------------------------------------------------------------
    def reset(self, seed: int = 0, *, sim=None, digs=None) -> None:
        """Start an episode with ``seed`` (abandoning a running one, see :meth:`close`).

        Args:
            seed: the episode seed (the scanner's noise and drift; the soil's too when the world is built here).
            sim: the world, as built (default: the task builds one with ``seed``).
            digs: where each cycle's dig comes from (default: the task's own, e.g. trenching's planner with a
                fresh memory of failed digs).
        """
        self.close()
        self._wall_s = 0.0
        self._t0 = time.perf_counter()
        self.seed = seed
        started = self.task.reset(seed, sim, digs)
        self.sim = started[0]
        self.digs_done = 0
        self.emap = None  # the map the dig source believes, this cycle
        self.choice: Choice | None = None
        self.dug: tuple | None = None  # the last dig's ``dug`` hook arguments after the index
        self.result = None
        self.end, self.reason = "budget", self.task.budget_reason(self.dig_budget)
        self.observer.started(*started)
        self.sim.step_hooks.append(self.observer.stepped)
        self._hooked = True
        self.over = False
        self._phase = "look"
        self._wall_s += time.perf_counter() - self._t0

    @property
    def index(self) -> int:
        """The cycle's number, 1-based: the digs done so far plus one."""
        return self.digs_done + 1

    def step(self) -> None:
        """One cycle: :meth:`look`, :meth:`decide` (the dig source's dig), :meth:`dig`, as far as the episode goes."""
        self.look()
        if not self.over:
            self.decide()
        if not self.over:
            self.dig()

    def run(self):
        """Cycle until the episode ends; its result."""
        while not self.over:
            self.step()
        return self.result

    # -- the phases ----------------------------------------------------------------------------------
    def look(self):
        """Park, scan and test the stopping rules; the map the dig source believes (None when the episode ended)."""
        with self._clock("look"):
            i, task = self.digs_done, self.task
            if self._elapsed() > task.wall_limit_s:
                return self._end("timeout", f"the episode's wall-clock limit of {task.wall_limit_s:g} s passed "
                                            f"after {i} digs")
            try:
                task.park()
            except (Diverged, OutOfTime) as exc:  # in the moves between digs: no dig to record
                return self._end(*world_failed(exc, f"parking after {i} digs"))
            scanned, detail = task.scan()
            self.observer.scanned(i + 1, scanned, detail)
            self.emap, stop = task.assess(i + 1, scanned, self.say)
            if stop is not None:
                return self._end(*stop)
            if i == self.dig_budget:  # the last scan only checks whether the budget's digs finished the task
                return self._end(self.end, self.reason)
            self._phase = "decide"
            return self.emap

    def decide(self, choice: Choice | None = None) -> Choice:
        """The cycle's dig: ``choice``, or the task's dig source's on the believed map; no dig ends the episode."""
        with self._clock("decide"):
            if choice is None:
                choice = self.task.choose(self.emap)
            self.choice = choice
            if choice.plan is not None or choice.dig is not None:
                self.observer.planned(self.index, choice.plan, choice.dig)
            if choice.dig is None:
                self._end("no_dig", choice.reason)
                return choice
            if choice.note:
                self.say(choice.note)
            self._phase = "dig"
            return choice

    def dig(self) -> tuple | None:
        """Execute the decided dig and let the soil settle; the ``dug`` hook's arguments after the index
        (for trenching the execution record and the dig's metrics), None when the world failed on the way."""
        with self._clock("dig"):
            i, task = self.index, self.task
            dug, stop = task.execute(i, self.choice)
            if dug is None:
                self._end(*stop)
                return None
            self.digs_done += 1
            self.dug = dug
            self.observer.dug(i, *dug)
            stop = task.after(i, self.choice, dug, self.say)
            if stop is not None:
                self._end(*stop)
            elif not task.final_scan and self.digs_done == self.dig_budget:
                self._end(self.end, self.reason)
            else:
                self._phase = "look"
            return dug

    def close(self) -> None:
        """Abandon a running episode: its observers hear ``finished(None)``; the world is left as it is."""
        if not self.over:
            self._unhook()
            self.over = True
            self._phase = "none"
            self.observer.finished(None)

    # -- inside ----------------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _clock(self, phase: str):
        """Run a phase: in order, on the wall clock, with the world's wall deadline set; an error ends the episode."""
        if self._phase != phase:
            raise EpisodeError(f"the episode cannot {phase} now: "
                               + ("it has ended (or never started); call reset() first" if self.over
                                  else f"the next phase is {self._phase}"))
        self._t0 = time.perf_counter()
        if hasattr(self.sim, "wall_deadline"):
            self.sim.wall_deadline = self._t0 + self.task.wall_limit_s - self._wall_s
        try:
            yield
        except BaseException:
            self.close()
            raise
        finally:
            if hasattr(self.sim, "wall_deadline"):
                self.sim.wall_deadline = None
            self._wall_s += time.perf_counter() - self._t0

    def _elapsed(self) -> float:
        """Wall time of the episode so far [s] (inside its phases)."""
        return self._wall_s + time.perf_counter() - self._t0

    def _end(self, end: str, reason: str) -> None:
        """End the episode: the task's result, then ``finished``."""
        self.end, self.reason = end, reason
        self.result = self.task.result(end, reason, self._elapsed())
        self._unhook()
        self.over = True
        self._phase = "none"
        self.observer.finished(self.result)

    def _unhook(self) -> None:
        if hasattr(self.sim, "wall_deadline"):
            self.sim.wall_deadline = None
        if self._hooked:
            self.sim.step_hooks.remove(self.observer.stepped)
            self._hooked = False


class _Unobserved:
    """No observer: every hook, with any task's arguments, does nothing."""

    def started(self, *args) -> None: ...
    def scanned(self, *args) -> None: ...
    def planned(self, *args) -> None: ...
    def stepped(self, *args) -> None: ...
    def dug(self, *args) -> None: ...
    def finished(self, *args) -> None: ...



def world_failed(exc: Diverged | OutOfTime, where: str) -> tuple[str, str]:
    """The episode's end and reason when the world failed outside a dig (``where``: what the loop was doing)."""
    return ("diverged" if isinstance(exc, Diverged) else "timeout"), f"{exc} ({where})"

