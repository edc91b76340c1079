"""Rowe's mass-excavation script (Rowe 1997 §4.3 and §6.2's listing, Fig. 4) on the script engine.

After a dig, four single-joint sub-scripts run side by side, coupled through conditions on the other
joints: swing, boom, stick and bucket (:class:`ScriptJoints` names them on a machine; positive angles
raise the boom, extend the stick and open the bucket, as in the thesis' listing; joints beside them,
the T3's wrist yaw and roll, are held level)::

    Swing:  1) when digging finishes, wait                        -> swing_dig
            2) when boom > boom_trigger, swing to the truck       -> swing_dump
            3) when bucket > bucket_return, swing to the dig face -> swing_dig
            4) when swing < swing_dig + stop_tol, stop to dig     (ends the script)
    Boom:   1) when digging finishes, raise boom                  -> boom_carry
            2) when swing > swing_dump - open_lead [and stick past stick_open], begin dump -> boom_dump
            3) [when bucket > bucket_dumped, continue to dump     -> boom_carry]
            4) when swing < swing_back, lower boom to dig         -> boom_dig
    Stick:  1) when digging finishes, wait                        -> stick_carry
            2) when swing is stick_fraction of the way to the truck, begin dump procedure -> stick_dump
            3) [when bucket > bucket_dumped, continue to dump     -> stick_after]
            4) when swing < swing_back, move to dig               -> stick_dig
    Bucket: 1) when digging finishes, capture soil                -> bucket_carry
            2) when swing > swing_dump - open_lead [and stick past stick_open], open -> bucket_open
            3) when swing < swing_back, move to dig               -> bucket_dig

The bracketed parts are §6.2's listing as the T3 runs it; a machine whose parameters leave
``stick_open_fraction`` or ``dumped_fraction`` out (None) runs without them (the 25 t: its boom and stick hold
the dump pose until the swing is on its way back). The comparisons turn with the swing's direction (the
listing's swing turns positive towards the truck). Two of the triggers are written as shares of a motion
(``stick_fraction`` of the swing's travel, ``return_fraction`` of the bucket's opening) so that no tuned
value can leave a trigger that never fires (assumed). On the T3, the bucket-open lead ``open_lead`` mostly
sets nothing: at the computed parameters the stick's condition of the same rule holds later than the
swing's (the stick starts at ``stick_fraction`` of the swing and must be ``stick_open_fraction`` out), so
the bucket opens when the stick is out (measured: the same trial for any lead within +-10 deg); the stick's
trigger is the one that sets when the dump begins.
"""

from __future__ import annotations

import dataclasses

from excavsim.execution.conditions import Cond, all_of, always, joint_above, joint_below, started
from excavsim.execution.rowe_script.params import RoweParams
from excavsim.execution.script import Command, Script, Step, SubScript


@dataclasses.dataclass(frozen=True)
class ScriptJoints:
    """A machine's joints as the script drives them: the joint names of the four roles and the joints held
    level (at 0 rad) beside them. The servos' arrays are in :attr:`order`."""

    swing: str
    boom: str
    stick: str
    bucket: str
    level: tuple[str, ...] = ()

    @property
    def order(self) -> tuple[str, ...]:
        """The joints in the servos' order: swing, boom, stick, bucket, then the level joints."""
        return (self.swing, self.boom, self.stick, self.bucket, *self.level)


def passing(joint: str, start: float, end: float, fraction: float) -> Cond:
    """Holds once ``joint``, moving from ``start`` to ``end`` [rad], is ``fraction`` of the way."""
    at = start + fraction * (end - start)
    return joint_above(joint, at) if end >= start else joint_below(joint, at)


def rowe_script(p: RoweParams, joints: ScriptJoints) -> Script:
    """The mass-excavation script with the parameters ``p`` on ``joints`` (see the module docstring)."""
    swing_j, boom_j, stick_j, bucket_j = joints.swing, joints.boom, joints.stick, joints.bucket
    out = p.swing_dump >= p.swing_dig  # the swing turns positive towards the truck

    def go(*targets: float) -> Command:
        return Command(tuple(float(t) for t in targets))

    def toward(joint: str, at: float, rising: bool) -> Cond:
        return joint_above(joint, at) if rising else joint_below(joint, at)

    near_dump = toward(swing_j, p.swing_dump - p.open_lead if out else p.swing_dump + p.open_lead, out)
    open_at = near_dump if p.stick_open_fraction is None else \
        all_of(near_dump, passing(stick_j, p.stick_carry, p.stick_dump, p.stick_open_fraction))
    # back at the dig side: once the swing has started back (an engine event; the thesis' "swing < 60 deg"
    # alone would hold on the way out as well when the bucket opens before the swing passes it)
    back = all_of(started("swing to dig face"), toward(swing_j, p.swing_back, not out))
    arrived = toward(swing_j, p.swing_dig + p.stop_tol if out else p.swing_dig - p.stop_tol, not out)
    swing = (Step("swing wait", always(), go(p.swing_dig)),
             Step("swing to truck", joint_above(boom_j, p.boom_trigger), go(p.swing_dump)),
             # only once the bucket is opening: the bucket starts the script curled beyond its dig angle
             # only when the dig ends curled, and a learned share must not send the swing back unloaded
             Step("swing to dig face", all_of(started("open bucket"),
                                              passing(bucket_j, p.bucket_carry, p.bucket_open, p.return_fraction)),
                  go(p.swing_dig)),
             Step("stop to dig", arrived, go(p.swing_dig), ends=always()))
    boom = [Step("raise boom", always(), go(p.boom_carry)), Step("boom dump", open_at, go(p.boom_dump))]
    stick = [Step("stick wait", always(), go(p.stick_carry)),
             Step("stick out", passing(swing_j, p.swing_dig, p.swing_dump, p.stick_fraction), go(p.stick_dump))]
    if p.dumped_fraction is not None:
        dumped = passing(bucket_j, p.bucket_carry, p.bucket_open, p.dumped_fraction)
        boom.append(Step("boom continue", dumped, go(p.boom_carry)))
        stick.append(Step("stick continue", dumped, go(p.stick_after)))
    boom.append(Step("lower boom", back, go(p.boom_dig)))
    stick.append(Step("stick to dig", back, go(p.stick_dig)))
    bucket = (Step("capture", always(), go(p.bucket_carry)),
              Step("open bucket", open_at, go(p.bucket_open)),
              Step("bucket to dig", back, go(p.bucket_dig)))
    subs = [SubScript((swing_j,), swing), SubScript((boom_j,), tuple(boom)), SubScript((stick_j,), tuple(stick)),
            SubScript((bucket_j,), bucket)]
    if joints.level:
        subs.append(SubScript(joints.level, (Step("level", always(), go(*(0.0 for _ in joints.level))),)))
    return Script("mass excavation", tuple(subs), timeout_s=p.timeout_s)
