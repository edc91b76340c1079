"""Every number of Rowe's script, computed for each load (Rowe 1997 §4.2).

:func:`compute_params` fills :class:`RoweParams` from three things: the geometry (a dump rule of
:mod:`~excavsim.execution.rowe_script.geometry` chooses the carry and dump poses and the boom's clearance
angles over the truck's side, Fig. 3), the machine's timing (a
:class:`~excavsim.execution.rowe_script.timing.MachineTiming`: the boom trigger of Fig. 4 lets the swing
start before the boom is clear, timed so the boom reaches the clearance angle by the time the swing reaches
the truck's near edge; the bucket-open lead) and the machine's "magic numbers" (:class:`ScriptRules`:
shares of a motion that start the next step, §4.2). Some of the parameters are then tuned online (§6.2):
which ones is the task's choice (:meth:`RoweParams.values` and :meth:`RoweParams.with_values` read and
replace them by name). The truck itself is a :class:`~excavsim.execution.rowe_script.geometry.TruckSite`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from excavsim.execution.rowe_script.geometry import DumpRule, TruckSite
from excavsim.execution.rowe_script.timing import MachineTiming
from excavsim.robot.kinematics import PlanarArm


@dataclasses.dataclass(frozen=True, kw_only=True)
class RoweParams:
    """Every number of Rowe's script (angles [rad], shares [-]); see :mod:`~excavsim.execution.rowe_script.listing`
    for where each acts.

    Attributes:
        swing_dig, swing_dump: the swing at the dig and at the dump.
        stick_fraction: the share of the swing's travel at which the stick goes out.
        swing_back: past this on the way back, the arm goes to the next dig's pose.
        stop_tol: the swing is back within this of ``swing_dig``.
        open_lead: the bucket opens (and the boom goes to the dump) within this of ``swing_dump``.
        boom_trigger: the swing starts for the truck once the boom passes this.
        boom_carry, boom_dump, boom_dig: the boom carrying, dumping, and at the next dig.
        stick_carry, stick_dump, stick_dig: the stick likewise; ``stick_after`` after the dump (None: the
            stick holds the dump's angle until the swing is back).
        stick_open_fraction: the dump also waits for the stick to be this share out (None: the swing alone).
        bucket_carry, bucket_open, bucket_dig: the bucket likewise.
        return_fraction: the bucket's opening share that sends the swing back.
        dumped_fraction: at this opening share boom and stick continue (§6.2's "continue to dump"; None: no
            such step).
        timeout_s: the longest the script runs [s].
        boom_clear_dump, boom_clear: the boom's clearance angles over the truck's side (Fig. 3) at the dump's
            stick (the lowest safe ``boom_dump``) and at the carry's.
    """

    swing_dig: float
    swing_dump: float
    stick_fraction: float
    swing_back: float
    stop_tol: float
    open_lead: float
    boom_trigger: float
    boom_carry: float
    boom_dump: float
    boom_dig: float
    stick_carry: float
    stick_dump: float
    stick_after: float | None = None
    stick_dig: float
    stick_open_fraction: float | None = None
    bucket_carry: float
    bucket_open: float
    bucket_dig: float
    return_fraction: float
    dumped_fraction: float | None = None
    timeout_s: float = 40.0
    boom_clear_dump: float = -math.inf
    boom_clear: float = -math.inf

    #: the parameters that are shares of a motion [-] or a time [s]; the others are angles [rad]
    PLAIN = ("stick_fraction", "return_fraction", "dumped_fraction", "stick_open_fraction", "timeout_s")

    def values(self, names: Sequence[str]) -> np.ndarray:
        """The parameters ``names`` as a vector (a learner's input), in that order."""
        return np.array([getattr(self, n) for n in names], dtype=float)

    def with_values(self, names: Sequence[str], x: Sequence[float]) -> RoweParams:
        """These parameters with ``names`` replaced by ``x`` (in that order)."""
        return dataclasses.replace(self, **{n: float(v) for n, v in zip(names, x)})

    def degrees(self) -> dict[str, float]:
        """Every parameter the script uses, angles in degrees (shares and the timeout as they are), for logs."""
        return {f.name: (v if f.name in self.PLAIN else math.degrees(v))
                for f in dataclasses.fields(self) if (v := getattr(self, f.name)) is not None and math.isfinite(v)}


@dataclasses.dataclass(frozen=True)
class ScriptRules:
    """How a machine's parameters are computed beside the geometry and the timing: its dump rule and its
    "magic numbers" (§4.2: heuristics of the script's author, every one assumed).

    Attributes:
        dump: the rule that chooses the carry and dump poses.
        stick_fraction: the stick goes out at this share of the swing's travel.
        back_fraction: on the way back the arm goes to the next dig past this share of the swing's
            travel from the dig (clear of the truck).
        stop_tol: the swing counts as back within this of the dig's angle [rad].
        return_fraction: the bucket's opening share that sends the swing back.
        stick_open_fraction, dumped_fraction: see :class:`RoweParams` (None: no such condition or step).
        safety: the boom trigger leaves the boom this share of the swing's time to clear.
        tol: a joint error that counts as arrived [rad]; the trigger is at least this above the dig's boom.
        timeout_s: the longest the script runs [s].
    """

    dump: DumpRule
    stick_fraction: float
    back_fraction: float
    stop_tol: float
    return_fraction: float = 0.8
    stick_open_fraction: float | None = None
    dumped_fraction: float | None = None
    safety: float = 0.8
    tol: float = 0.01
    timeout_s: float = 40.0


def compute_params(arm: PlanarArm, site: TruckSite, rules: ScriptRules, timing: MachineTiming, dig_end: np.ndarray,
                   swing_dig: float, *, dump_at: tuple[float, float] | None = None,
                   return_pose: np.ndarray | None = None, return_fraction: float | None = None,
                   trigger_lead: float = 0.0) -> RoweParams:
    """The script's parameters for one load (§4.2): geometry for the commands, the timing for the triggers.

    Args:
        arm: the robot's planar kinematics.
        site: the truck.
        rules: the machine's dump rule and heuristics.
        timing: the machine model.
        dig_end: (3,) boom, stick and bucket angles when digging finished [rad] (clipped to the joint
            limits: the encoders may read a hair past a limit, the commands stay within them).
        swing_dig: the swing angle of the dig face [rad].
        dump_at: where the soil goes (r [m], theta [rad]); default the site's centre.
        return_pose: (3,) boom, stick, bucket [rad] of the next dig's start (clipped to the limits); default
            the dig's end.
        return_fraction: replaces ``rules.return_fraction`` (tuned).
        trigger_lead: how much earlier than the timing model's trigger the swing starts [rad].

    Raises:
        GoalError: the dump pose is out of reach or the bucket cannot clear the side.
    """
    boom0, stick0, bucket0 = (float(v) for v in np.clip(dig_end, arm.lower, arm.upper))
    dump_r, dump_theta = dump_at if dump_at is not None else (site.r_d, site.theta_d)
    p = rules.dump.poses(arm, site, (boom0, stick0, bucket0), dump_r)
    # Fig. 4's trigger: the swing reaches the truck's edge after the swing's time; the boom, rising at its
    # rate, must pass the clearance angle by then, so the swing may start that much below it
    t_swing = timing.swing_time(site.edge_swing - swing_dig)
    trigger = p.clear - rules.safety * timing.boom_rate() * t_swing - trigger_lead
    boom_trigger = float(np.clip(trigger, boom0 + rules.tol, p.clear))
    open_lead = timing.open_lead(p.bucket_open - p.bucket_carry, rules.tol)
    swing_back = swing_dig + rules.back_fraction * (dump_theta - swing_dig)
    back = ((boom0, stick0, bucket0) if return_pose is None
            else tuple(float(v) for v in np.clip(return_pose, arm.lower, arm.upper)))
    dumped = rules.dumped_fraction is not None
    return RoweParams(swing_dig=swing_dig, swing_dump=dump_theta, stick_fraction=rules.stick_fraction,
                      swing_back=swing_back, stop_tol=rules.stop_tol, open_lead=open_lead, boom_trigger=boom_trigger,
                      boom_carry=p.boom_carry, boom_dump=p.boom_dump, boom_dig=back[0], stick_carry=p.stick_carry,
                      stick_dump=p.stick_dump, stick_after=p.stick_carry if dumped else None, stick_dig=back[1],
                      stick_open_fraction=rules.stick_open_fraction, bucket_carry=p.bucket_carry,
                      bucket_open=p.bucket_open, bucket_dig=back[2],
                      return_fraction=float(rules.return_fraction if return_fraction is None else return_fraction),
                      dumped_fraction=rules.dumped_fraction, timeout_s=rules.timeout_s,
                      boom_clear_dump=p.clear_dump, boom_clear=p.clear)
