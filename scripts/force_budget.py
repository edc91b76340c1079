"""Where a dig's wrist torque comes from: the planner's prediction against the world's force terms.

For every dig of an episode this prints the wrist-pitch torque the planner predicted along the
planned path (its peak per phase: penetrate, drag, curl) and what the executor met: the measured
actuator torque, and the part of the soil's wrench on the bucket that each term of the world's
model contributes to the wrist (through MuJoCo's Jacobian of the bucket's centre of mass): the
wedge's cutting force at the edge, bearing and friction on the bucket's outer surface (with rocks),
and the load's weight. It also says where the bucket's rake was below the penetration's
alpha + epsilon, the case of Fig. 19 in which the bottom of the bucket bears on the soil.

    python scripts/force_budget.py --goal small --seed 3 --dig-budget 4

Privileged truth, for diagnosis: the robot's mind never sees these terms.
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np

from excavsim.handoff.episode import EpisodeObserver
from excavsim.loop.scenario import EpisodeSpec, run_spec

WRIST = 3  # wrist pitch in constants.JOINTS order
PHASES = ("penetrate", "drag", "curl")


class ForceBudget(EpisodeObserver):
    """Records, at every control step, the wrist torque of each soil force term."""

    def started(self, sim, rig, goal_mask, goal_z):
        self.sim, self.rig = sim, rig
        m = sim.model
        self.body = sim.index.bucket_body
        self.dof = sim.index.dof
        self.jacp = np.zeros((3, m.nv))
        self.jacr = np.zeros((3, m.nv))
        self.steps: list[tuple] = []
        self.rows: list[dict] = []
        self.plan = None

    def planned(self, index, plan, dig):
        self.dig, self.plan = dig, plan
        self.steps = []

    def stepped(self, sim):
        c = sim.contact
        if c is None:
            return
        d = sim.data
        mujoco.mj_jacBodyCom(sim.model, d, self.jacp, self.jacr, self.body)
        com = d.xipos[self.body]
        rot = d.xmat[self.body].reshape(3, 3)
        rec = c.record
        edge = np.asarray(rec["edge_centre_m"]).reshape(3)
        load_at = rot @ sim.soil.bucket.load_centroid + d.xpos[self.body]
        f_cut, w = c.cutting_force, c.load_weight
        m_cut = np.cross(edge - com, f_cut)
        m_load = np.cross(load_at - com, w)
        f_rest = c.force - f_cut - w
        m_rest = c.torque - m_cut - m_load

        def wrist(f, m_):  # generalized force on wrist pitch of a wrench at the COM
            return float((self.jacp.T @ f + self.jacr.T @ m_)[self.dof[WRIST]])

        self.steps.append((float(d.time), sim.joint_angles(), float(d.actuator_force[sim.index.actuator[WRIST]]),
                           wrist(f_cut, m_cut), wrist(f_rest, m_rest), wrist(w, m_load), c.depth_m, c.rake_rad,
                           float(np.linalg.norm(c.force - w)), sim.soil.load))

    def dug(self, index, record, metrics):
        if not self.steps or self.dig is None:
            return
        t = np.array([s[0] for s in self.steps])
        lo, hi = record.phase_starts.get("dig", np.inf), record.phase_starts.get("lift out", np.inf)
        if record.stall:
            hi = min(hi, record.stall["time"])
        sel = (t >= lo) & (t < hi)
        row = {"index": index, "kind": metrics.kind, "action": metrics.action, "outcome": record.outcome}
        # the planner's prediction per phase (static joint torques along the planned path)
        plan = self.plan
        if plan is not None and metrics.kind == "planned" and len(plan.torques):
            for p, name in enumerate(PHASES):
                on = plan.phases == p
                row[f"pred_{name}"] = float(np.abs(plan.torques[on, 2]).max()) if on.any() else math.nan
        if sel.any():
            q = np.stack([s[1] for s in self.steps])[sel]
            tips = self.rig.arm.forward(q[:, 1:4])
            path = record.planned_path if record.planned_path is not None else self.dig.poses
            near = np.argmin(np.linalg.norm(tips[:, None, :2] - path[None, :, :2], axis=-1), axis=1)
            phase = self.dig.phases[near]
            act = np.array([s[2] for s in self.steps])[sel]
            parts = np.array([s[3:6] for s in self.steps])[sel]
            rake = np.array([s[7] for s in self.steps])[sel]
            depth = np.array([s[6] for s in self.steps])[sel]
            force = np.array([s[8] for s in self.steps])[sel]
            load = np.array([s[9] for s in self.steps])[sel]
            for p, name in enumerate(PHASES):
                on = phase == p
                if not on.any():
                    continue
                k = int(np.argmax(np.abs(act[on])))
                row[f"meas_{name}"] = float(abs(act[on][k]))
                row[f"terms_{name}"] = tuple(float(v) for v in parts[on][k])
                row[f"depth_{name}"] = float(depth[on][k])
                row[f"force_{name}"] = float(force[on].max())
                row[f"load_{name}"] = float(load[on][k])
            if metrics.action is not None:
                low = rake < metrics.action[1] + math.radians(self.rig.planner_cfg.epsilon_deg) - 1e-6
                row["rake_below_share"] = float(np.mean(low[depth > 0])) if np.any(depth > 0) else 0.0
        self.rows.append(row)


def format_rows(rows: list[dict]) -> str:
    lines = [f"{'dig':>3} {'action (k, alpha, d1, d2)':<26} {'outcome':<15} {'phase':<9} {'pred':>6} {'meas':>6} "
             f"{'cut':>6} {'bear':>6} {'load':>6} {'depth':>6} {'|F|':>6} {'fill':>5}  wrist pitch [N m], depth [cm], "
             "peak soil force [N], load [l]"]
    for r in rows:
        act = r["action"]
        label = (f"{act[0]:.2f} {math.degrees(act[1]):3.0f} {act[2]:.2f} {act[3]:.2f}" if act is not None
                 else r["kind"][:26])
        first = True
        for name in PHASES:
            if f"meas_{name}" not in r and f"pred_{name}" not in r:
                continue
            cut, bear, load = r.get(f"terms_{name}", (math.nan,) * 3)
            head = f"{r['index']:>3} {label:<26} {r['outcome']:<15}" if first else " " * 46
            pred, meas = r.get(f"pred_{name}", math.nan), r.get(f"meas_{name}", math.nan)
            lines.append(f"{head} {name:<9} {pred:6.0f} {meas:6.0f} "
                         f"{cut:6.0f} {bear:6.0f} {load:6.0f} {100 * r.get(f'depth_{name}', math.nan):6.1f} "
                         f"{r.get(f'force_{name}', math.nan):6.0f} {1000 * r.get(f'load_{name}', math.nan):5.1f}")
            first = False
        if "rake_below_share" in r:
            lines.append(" " * 46 + f" rake below alpha + epsilon on {100 * r['rake_below_share']:.0f} % of the "
                                    "in-soil steps (Fig. 19: the bottom bears)")
    lines.append("pred: the planner's static wrist torque (peak in the phase); meas: the actuator's (peak); cut, "
                 "bear, load: the wrist torque of the soil's cutting force, of bearing + friction (+ rocks), and of "
                 "the load's weight, at the measured peak (the rest is the bucket's own weight and inertia); |F|: the peak "
                 "magnitude of the soil's force on the bucket without the load's weight; fill: the load at the peak")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--goal", default="small")
    parser.add_argument("--soil", default=None)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--dig-budget", type=int, default=4)
    parser.add_argument("--wrist-limit", type=float, default=None, help="wrist pitch relief [N m]")
    parser.add_argument("--no-load-surcharge", action="store_true",
                        help="the world without the load's surcharge on the wedge (scene.bucket.load_surcharge false)")
    args = parser.parse_args(argv)
    robot = {"joints": {"wrist_pitch": {"torque_limit_nm": args.wrist_limit}}} if args.wrist_limit else {}
    spec = EpisodeSpec(name="force-budget", goal=args.goal, soil=args.soil, seed=args.seed,
                       dig_budget=args.dig_budget, robot=robot,
                       scene={"bucket": {"load_surcharge": False}} if args.no_load_surcharge else {})
    budget = ForceBudget()
    run_spec(spec, observer=budget)
    print(format_rows(budget.rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
