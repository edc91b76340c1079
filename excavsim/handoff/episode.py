"""An episode's hooks and results: what the loop hands to its observers (the recorder, learners).

:class:`EpisodeObserver` is the set of hooks the episode (:class:`~excavsim.loop.episode.Episode`)
calls; the Rerun recorder and the online learner implement them, and the caller hands them to the
loop, which never imports them. :class:`DigMetrics` and :class:`EpisodeResult` are the numbers of
one dig and of the episode; :func:`format_episode` prints them as a table.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from excavsim.handoff.dig import Dig


class EpisodeObserver:
    """Hooks into an episode; a recorder overrides the ones it needs (every default does nothing).

    Calls, in order: :meth:`started` once; per cycle :meth:`scanned`, then :meth:`planned` (with
    the planner's :class:`~excavsim.planning.search.PlanResult` and the chosen
    :class:`~excavsim.handoff.dig.Dig`, or None when there is none), :meth:`stepped` after every
    control step of the dig and the moves around it, :meth:`dug` after the soil settled;
    :meth:`finished` once at the end, also when the episode raised (then with None).

    These six hooks are the one observer protocol of every task of the episode
    (:class:`~excavsim.loop.episode.Episode`); the arguments below are the trenching task's. A
    task names its own: loading from a pile calls ``started(world, machine)``, ``scanned(index,
    emap, terrain)``, ``planned(index, plan, tip_path)``, ``stepped(world)``, ``dug(index, dig)``
    and ``finished(run)`` (its folder's ``LoadingObserver``).
    """

    def started(self, sim, rig, goal_mask: np.ndarray, goal_z: np.ndarray) -> None:
        """The world and the loop's pieces before the first scan."""

    def scanned(self, index: int, emap, accuracy) -> None:
        """The elevation map of cycle ``index`` (1-based) and its accuracy against the truth."""

    def planned(self, index: int, plan, dig: Dig | None) -> None:
        """The planner's result of cycle ``index`` (None when the dig source did not plan) and the dig
        chosen (the planner's, a boundary-following fallback, ...; None when there is none)."""

    def stepped(self, sim) -> None:
        """After each control step."""

    def dug(self, index: int, record, metrics: DigMetrics) -> None:
        """The execution record and metrics of dig ``index``, after settlement."""

    def finished(self, result: EpisodeResult | None) -> None:
        """The episode's result (None when it ended with an error)."""


class ObserverGroup(EpisodeObserver):
    """Several observers of one episode (a recorder and a learner, say), called in order, with the
    hooks' arguments of whatever task the episode runs."""

    def __init__(self, *observers: EpisodeObserver):
        self.observers = [o for o in observers if o is not None]

    def started(self, *args):
        for o in self.observers:
            o.started(*args)

    def scanned(self, *args):
        for o in self.observers:
            o.scanned(*args)

    def planned(self, *args):
        for o in self.observers:
            o.planned(*args)

    def stepped(self, *args):
        for o in self.observers:
            o.stepped(*args)

    def dug(self, *args):
        for o in self.observers:
            o.dug(*args)

    def finished(self, *args):
        for o in self.observers:
            o.finished(*args)


@dataclasses.dataclass
class DigMetrics:
    """One dig of an episode; ``kind`` is "planned" or "fallback: <boundary>" (§7.2).

    Peak and cumulative joint torques cover the soil-loaded part of the dig (touch-down to the end
    of the lift-out), sampled at the F/T rate.

    Attributes:
        predicted_m3, bucket_m3: the swept volume the dig was chosen for, and the soil in the bucket
            at lift-out (truth) [m^3]; weighed_m3: the load as the F/T sensor weighed it [m^3].
        peak_torque_nm: (6,) measured peak actuator torques [N m]; predicted_peak_nm: (3,) the
            planner's predicted peak static torques at shoulder, elbow, wrist pitch [N m] (NaN: none).
        failure: what went wrong as the robot sees it (stall, no contact, timeout, diverged, simulation
            failure, little soil: less than 1 l weighed), or None.
    """

    index: int
    kind: str
    action: tuple[float, float, float, float] | None
    outcome: str
    predicted_m3: float
    bucket_m3: float
    efficiency: float
    stall_joint: str | None
    planning_s: float
    sim_s: float
    peak_torque_nm: np.ndarray
    cumulative_torque_nm_s: float
    predicted_peak_nm: np.ndarray = dataclasses.field(default_factory=lambda: np.full(3, np.nan))
    weighed_m3: float = float("nan")
    failure: str | None = None

    @property
    def failed(self) -> bool:
        """The dig failed in the world: a stall, no contact, a timeout, a divergence, or under 1 l in the
        bucket (truth)."""
        return self.failure not in (None, "little soil") or not self.bucket_m3 >= 0.001


@dataclasses.dataclass
class EpisodeResult:
    """An episode's digs, its end, and the trench against the goal (true terrain)."""

    digs: list[DigMetrics]
    end: str  # "done", "no_dig", "budget", "diverged" or "timeout" (the wall-clock limit)
    reason: str
    goal_m3: float
    removed_m3: float
    overdig_max_m: float
    overdig_rms_m: float
    underdig_max_m: float
    underdig_rms_m: float
    sim_time_s: float
    wall_time_s: float
    volume_change_m3: float
    task: str = ""  # the task whose episode it is (its plug-in's name; empty when made outside a task)

    @property
    def removed_fraction(self) -> float:
        return self.removed_m3 / self.goal_m3 if self.goal_m3 > 0 else float("nan")


def format_episode(res: EpisodeResult) -> str:
    """The per-dig table and the episode summary."""
    lines = ["", f"{'dig':>3} {'k m':>5} {'alpha':>5} {'d1 m':>5} {'d2 m':>5} {'plan l':>7} {'dug l':>6} "
                 f"{'eff':>5} {'outcome':<15} {'failure':<12} {'stall':<18} {'wrist pred/meas':>15}"]
    for d in res.digs:
        if d.action is None:  # a boundary-following fallback dig
            act = f"{d.kind[len('fallback: '):]:>23.23}"
        else:
            k, a, d1, d2 = d.action
            act = f"{k:5.2f} {math.degrees(a):5.0f} {d1:5.2f} {d2:5.2f}"
        wrist = f"{d.predicted_peak_nm[2]:.0f}/{d.peak_torque_nm[3]:.0f}"
        lines.append(f"{d.index:>3} {act} {1000 * d.predicted_m3:7.1f} "
                     f"{1000 * d.bucket_m3:6.1f} {d.efficiency:5.2f} {d.outcome:<15} {d.failure or '-':<12} "
                     f"{d.stall_joint or '-':<18} {wrist:>15}")
    lines += ["", "wrist pred/meas: the planner's predicted and the measured peak wrist-pitch torque [N m]",
              f"ended: {res.reason}",
              f"removed {1000 * res.removed_m3:.1f} l of {1000 * res.goal_m3:.1f} l "
              f"({100 * res.removed_fraction:.0f} %); "
              f"over-dig max {100 * res.overdig_max_m:.1f} cm (RMS {100 * res.overdig_rms_m:.1f}); under-dig max "
              f"{100 * res.underdig_max_m:.1f} cm (RMS {100 * res.underdig_rms_m:.1f})",
              f"{len(res.digs)} digs, {sum(d.stall_joint is not None for d in res.digs)} stalls, "
              f"{sum(d.outcome == 'diverged' for d in res.digs)} diverged, "
              f"{sum(d.failed for d in res.digs)} failed (stall, no contact, timeout, diverged or under 1 l); "
              f"simulated "
              f"{res.sim_time_s:.0f} s in {res.wall_time_s:.1f} s wall; "
              f"soil volume change {res.volume_change_m3:.1e} m^3"]
    return "\n".join(lines)
