"""What the planner hands to the executor, and what the executor reports back.

:class:`TrenchAction` is the trenching action of Singh 1995 §3.4.1 with its
dependent drag length; :class:`DigPlan` is the tip path the executor follows (from the planner or
from the boundary-following fallback, §7.2); :class:`ExecutionRecord` is what happened while it
ran, at sensor level: the loop turns it into metrics, learning into force samples.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from excavsim.handoff.goal import SurfaceProfile


class TrenchAction(NamedTuple):
    """One trenching dig (§3.4.1): enter at ``k``, penetrate ``d1`` at ``alpha``, drag ``d2``, curl.

    Attributes:
        k: radial distance of the entry from the waist axis [m].
        alpha: approach angle below horizontal [rad].
        d1: penetration length [m].
        d2: drag length [m] (the planner's dependent variable).
    """

    k: float
    alpha: float
    d1: float
    d2: float


# k [m], alpha [rad], d1 [m], d2 [m]: about a bucketful from the flat 0.5 m fill, 13 cm deep. The
# hand-picked dig of ``excavsim demo`` (:mod:`excavsim.tasks.trench.demo`) and the cut whose record is
# the playback's demonstration on the T3 (:mod:`excavsim.apps.playback.servo_arm`): shared by a task and an application.
DEMO_ACTION = TrenchAction(2.2, math.radians(40.0), 0.2, 0.4)


@dataclasses.dataclass(frozen=True)
class DigPlan:
    """What the executor needs from a plan: the tip path in the arm plane and where it is.

    Attributes:
        poses: (S, 3) planned tip poses (x, z, pitch) [m, m, rad] from entry to the end of the curl.
        phases: (S,) 0 penetrate, 1 drag, 2 curl.
        waist: waist angle of the arm plane [rad].
        volume_m3: swept volume the planner predicted.
        shift_bounds_m: (lowest, highest) vertical shift of the path by the touch-down offset [m].
            The loop bounds it below by the path's clearance above the goal, so that a map error
            never makes the executor cut below the goal; a boundary-following dig is not shifted
            up either, since its job is the goal's shape, not the planned volume.
        surface: the mapped surface along the arm plane that the dig was planned on; touch-down
            then expects contact where the whole bucket first meets it, not where the tip does
            (Fig. 105: the bucket's heel on a slope touches first). None: at the entry's height.
    """

    poses: np.ndarray
    phases: np.ndarray
    waist: float
    volume_m3: float
    shift_bounds_m: tuple[float, float] = (-math.inf, math.inf)
    surface: SurfaceProfile | None = None


@dataclasses.dataclass
class ExecutionRecord:
    """What happened during one dig, at sensor level (the executor never reads the world's truth).

    Attributes:
        outcome: "completed", "completed late" (a move timed out), "stalled", "no contact",
            "timeout in step ..." (the script's time limit), "diverged" (the physics became unstable;
            the reason is the last warning), "timeout: ..." (the episode's wall-clock limit passed),
            or "simulation failure: ...".
        planned_path: (S, 3) the planned path as executed, shifted by the touch-down offset.
        executed_path: tip poses (x, z, pitch) measured while digging, one per control step.
        ft, torques, times: F/T readings in the tip frame ``(time, (3,))``, actuator torques (6,) and
            their times, sampled at the F/T rate [s, N, N m].
        phase_times, phase_starts: duration and start of each step of the arm's script [s].
        touch_expected_z, touch_found_z, touch_offset_m: the touch-down (§7.1.3) [m].
        warnings: what went wrong without ending the dig.
        stall: the joint, time, tip pose and torque of a stall, or None.
        planned_volume_m3: the swept volume the planner predicted.
        bucket_volume_m3: soil in the bucket at lift-out: privileged truth, filled in by the loop
            from the world (NaN when the dig never lifted out).
        lifted_load_n: the load's weight as the F/T sensor weighed it while the lifted bucket was
            held (the median vertical force of the environment on the bucket) [N]: what the robot
            itself knows it brought up; NaN when the dig never lifted out.
        script_text: the script as run (:meth:`~excavsim.execution.script.Script.describe`).
        compliance: rise of the dig path per control step with compliance on [m].
    """

    outcome: str = "running"
    planned_path: np.ndarray | None = None
    executed_path: list[np.ndarray] = dataclasses.field(default_factory=list)
    ft: list[tuple[float, np.ndarray]] = dataclasses.field(default_factory=list)
    torques: list[np.ndarray] = dataclasses.field(default_factory=list)
    times: list[float] = dataclasses.field(default_factory=list)
    phase_times: dict[str, float] = dataclasses.field(default_factory=dict)
    phase_starts: dict[str, float] = dataclasses.field(default_factory=dict)  # simulated time [s]
    touch_expected_z: float = float("nan")
    touch_found_z: float = float("nan")
    touch_offset_m: float = 0.0
    warnings: list[str] = dataclasses.field(default_factory=list)
    stall: dict | None = None
    planned_volume_m3: float = 0.0
    bucket_volume_m3: float = float("nan")
    lifted_load_n: float = float("nan")
    script_text: str = ""
    compliance: list[float] = dataclasses.field(default_factory=list)

    def in_soil_window(self) -> tuple[float, float]:
        """Simulated time from touch-down to the end of the lift-out: when the soil loads the arm."""
        start = self.phase_starts.get("touch-down", -math.inf)
        ends = [self.phase_starts[n] + self.phase_times[n] for n in ("dig", "lift out") if n in self.phase_starts]
        return start, max(ends, default=math.inf)

    @property
    def completed(self) -> bool:
        """The dig ran to the park pose without a stall and every move settled in time."""
        return self.outcome == "completed"

    def path_error(self) -> float:
        """Largest distance of the executed tip path (dig phase) from the planned path [m]."""
        if self.planned_path is None or not self.executed_path:
            return float("nan")
        plan = self.planned_path[:, :2]
        ex = np.asarray(self.executed_path)[:, :2]
        # distance of each executed point to the planned polyline
        a, b = plan[:-1], plan[1:]
        ab = b - a
        t = np.clip(np.einsum("nij,ij->ni", ex[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
        d = np.linalg.norm(ex[:, None, :] - (a[None] + t[..., None] * ab[None]), axis=-1)
        return float(d.min(axis=1).max())


@dataclasses.dataclass(frozen=True)
class Dig:
    """The dig chosen for one cycle of an episode, before the executor runs it.

    Attributes:
        kind: where it came from: "planned", "fallback: <boundary>" (§7.2), or another source's label.
        poses: (S, 3) tip path (x, z, pitch) in the arm plane [m, m, rad].
        phases: (S,) 0 penetrate, 1 drag, 2 curl.
        volume_m3: the swept volume predicted on the map [m^3].
        action: the trenching action, or None for a dig that is not one (a boundary-following dig).
        planning_s: wall time spent choosing it [s].
        shift_up: whether the touch-down offset may shift the path up (a planned dig digs the volume
            it planned; a boundary-following dig keeps to the goal's shape and is never shifted up).
        predicted_peak_nm: (3,) the largest static torque the planner predicts along the path at
            shoulder, elbow and wrist pitch [N m] (NaN when it made no prediction).
    """

    kind: str
    poses: np.ndarray
    phases: np.ndarray
    volume_m3: float
    action: TrenchAction | None
    planning_s: float
    shift_up: bool = True
    predicted_peak_nm: np.ndarray = dataclasses.field(default_factory=lambda: np.full(3, np.nan))
