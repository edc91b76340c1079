"""The action-space trenching planner (000_a3ca905d8c6d92bf.txt ch. 3-6).

One dig is the trenching action (k, alpha, d1) of §3.4.1: enter the mapped surface at radial
distance ``k``; **penetrate** a straight line at ``alpha`` below horizontal for ``d1`` with rake
``alpha + epsilon`` (§3.4.2.2); **drag** horizontally towards the robot for ``d2`` while the rake
falls as ``max(zeta, rho_i - omega s)`` (eq. 1); **curl** about a centre behind the heel and
above the blade, ``r`` from the edge (Fig. 16's admissible region), turning the bucket to the end pitch, with the smallest radius of
``curl_radii_m`` whose end pose is reachable (§3.4.2.4, Fig. 23). ``d2`` is the dependent
variable: the longest drag on a ``sample_spacing_m`` grid that satisfies every constraint. It is
bounded by the constraints along the drag, then found by trying the curl from that bound down in
strides of four samples and refining upwards; a feasible drag that lies between strides below the
first feasible one can be missed (the curl's feasibility is not monotone in d2).

Constraints (ch. 4, §5.3), each evaluated on the tip path sampled every ``sample_spacing_m``, as a
vectorized mask over the candidates, cheapest first:

* **shaping**: no sample below the goal profile (``TrenchGoal``);
* **sensible**: every sample from entry to the end of the drag is in the soil, and the curl has
  turned the bucket to ``curl_exit_pitch_deg`` before the edge leaves the soil (§4.3.6: soil must
  not spill as the bucket moves through the air);
* **volume**: the swept area between the mapped surface and the path, times the bucket width, at
  most ``fill_fraction`` x capacity;
* **reachability**: the (z, pitch) lookup table first, exact elbow-up IK on the survivors;
* **force**: predicted soil forces (any :class:`~excavsim.planning.predictor.ForcePredictor`)
  and the swept soil's weight turned into joint torques ``tau = tau_grav - J^T F`` (eq. 28),
  within the relief limits at every sample.

Exhaustive search over the (k, alpha, d1) grid prunes along d1 at the first penetration that cuts
through the goal (§6.2.1: every longer penetration contains it). The objective is the swept volume,
the peak or the cumulative torque, or eq. 44: among digs sweeping at least ``volume_threshold`` of
the capacity, the smallest peak torque (the largest volume when none does). A best dig below
``min_volume_fraction`` of the capacity is "no dig" (the loop's boundary-following fallback, §7.2).

All of it is numpy on :class:`~excavsim.robot.kinematics.PlanarArm` and the elevation map: no MuJoCo.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from excavsim.config import PlannerConfig, TrenchGoal
from excavsim.errors import ExcavsimError
from excavsim.handoff.forces import DigContext, ForcePredictor, trajectory_progress
from excavsim.handoff.goal import SurfaceProfile, goal_profile
from excavsim.handoff.maps import ElevationMap
from excavsim.robot.fast import arm_params, ik_torques
from excavsim.robot.kinematics import PlanarArm
from excavsim.robot.reachability import ReachabilityTable

CONSTRAINTS = ("shaping", "sensible", "volume", "reachability", "force")
_NO_DIG = -1
_CURL_STRIDE = 4  # drag samples between the curls tried first


@dataclasses.dataclass
class PlanResult:
    """The planner's answer and everything it learned on the way (for logs and figures).

    ``action`` is (k, alpha, d1, d2) [m, rad, m, m] or None for "no dig"; per-cell arrays have the
    grid's shape (n_k, n_alpha, n_d1). ``masks`` holds, per constraint, the cells whose dig with the
    shortest drag satisfies that constraint (evaluated on every cell, for figures) and
    ``feasible`` the cells with some drag satisfying all of them.
    """

    action: tuple[float, float, float, float] | None
    reason: str
    utility: float
    volume_m3: float
    poses: np.ndarray
    phases: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    grid_k: np.ndarray
    grid_alpha: np.ndarray
    grid_d1: np.ndarray
    feasible: np.ndarray
    d2: np.ndarray
    volume: np.ndarray
    peak_torque_ratio: np.ndarray
    cumulative_torque: np.ndarray
    limiting: np.ndarray
    masks: dict[str, np.ndarray]
    counts: dict[str, int]
    seconds: float


class TrenchPlanner:
    """Plans one dig of a trench on an elevation map (see the module docstring).

    Args:
        arm: the planar chain.
        table: reachability table of ``arm``.
        torque_limits: (3,) relief limits of shoulder, elbow, wrist pitch [N m].
        bucket_width: [m]; bucket_capacity: struck capacity [m^3].
        goal: the trench.
        config: rules, grid and objective.
        predictor: force predictor for the force constraint.
        density: soil density for the load's weight [kg/m^3].
    """

    def __init__(self, arm: PlanarArm, table: ReachabilityTable, torque_limits: np.ndarray, bucket_width: float,
                 bucket_capacity: float, goal: TrenchGoal, config: PlannerConfig, predictor: ForcePredictor,
                 density: float = 2000.0):
        self.arm = arm
        self.table = table
        self.limits = np.asarray(torque_limits, dtype=float)
        if self.limits.shape != (3,) or np.any(self.limits <= 0):
            raise ExcavsimError(f"torque_limits must be 3 positive values [N m]; given {torque_limits!r}")
        self.width = float(bucket_width)
        self.capacity = float(bucket_capacity)
        self.goal = goal
        self.cfg = config
        self.predictor = predictor
        self.density = float(density)
        self._arm_params = arm_params(arm)
        self._load_tip = np.asarray(config.payload_com_tip_m, dtype=float)
        self._eps = math.radians(config.epsilon_deg)
        g = config.grid
        self.grid_k = _steps(g.k_min_m, g.k_max_m, g.k_step_m)
        self.grid_alpha = np.radians(_steps(g.alpha_min_deg, g.alpha_max_deg, g.alpha_step_deg))
        self.grid_d1 = _steps(g.d1_min_m, g.d1_max_m, g.d1_step_m)

    @property
    def grid_shape(self) -> tuple[int, int, int]:
        return len(self.grid_k), len(self.grid_alpha), len(self.grid_d1)

    # -- trajectories ---------------------------------------------------------------------------
    def penetrate(self, k, alpha, d1, surface: SurfaceProfile) -> np.ndarray:
        """(n, P, 3) penetrate poses for n actions, padded by repeating the end pose."""
        ds = self.cfg.sample_spacing_m
        n_s = int(math.ceil(self.grid_d1.max() / ds)) + 1
        s = np.minimum(np.arange(n_s)[None, :] * ds, d1[:, None])
        x = k[:, None] - s * np.cos(alpha)[:, None]
        z = surface(k)[:, None] - s * np.sin(alpha)[:, None]
        rho = np.broadcast_to((alpha + math.radians(self.cfg.epsilon_deg))[:, None], x.shape)
        return np.stack([x, z, rho], axis=-1)

    def drag(self, start: np.ndarray) -> np.ndarray:
        """(n, J, 3) drag poses from penetrate end poses ``start`` (n, 3): sample j is d2 = j ds."""
        ds = self.cfg.sample_spacing_m
        n_j = int(math.floor(self.cfg.d2_max_m / ds + 1e-9)) + 1
        s = np.arange(n_j) * ds
        x = start[:, None, 0] - s[None, :]
        z = np.broadcast_to(start[:, None, 1], x.shape)
        rho = np.maximum(math.radians(self.cfg.zeta_deg),
                         start[:, None, 2] - math.radians(self.cfg.omega_deg_per_m) * s[None, :])
        return np.stack([x, z, rho], axis=-1)

    def curl(self, start: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """(n, M, 3) curl poses from drag end poses ``start`` (n, 3) about centres ``radius`` away.

        The bucket turns clockwise in (x, z) to the end pitch about a centre ``radius`` from the edge
        along ``u = (b + z_t) / sqrt 2``, halfway between the blade's direction towards the heel
        ``b = (cos rho, sin rho)`` and its normal into the bucket ``z_t = (-sin rho, cos rho)``.
        Under that rotation a blade point ``s`` behind the edge moves along ``z_t`` at
        ``(r u.b - s) omega``: the bottom moves away from the soil (the admissible centres of
        Fig. 16) as long as ``r / sqrt 2`` exceeds the blade's length, hence radii from 0.35 m.
        A centre straight above the edge pressed the heel into the cut and stalled the wrist in
        the world.
        """
        rho0 = start[:, 2]
        turn = np.maximum(rho0 - math.radians(self.cfg.curl_end_pitch_deg), 0.0)
        frac = np.linspace(0.0, 1.0, self.cfg.curl_samples)
        th = turn[:, None] * frac[None, :]
        # centre behind the heel along the blade and above it: u = (b + z_t) / sqrt 2
        ux = (np.cos(rho0) - np.sin(rho0)) / math.sqrt(2.0)
        uz = (np.sin(rho0) + np.cos(rho0)) / math.sqrt(2.0)
        cx = start[:, 0] + radius * ux
        cz = start[:, 1] + radius * uz
        vx, vz = start[:, 0] - cx, start[:, 1] - cz
        c, s = np.cos(th), np.sin(th)
        x = cx[:, None] + c * vx[:, None] + s * vz[:, None]  # clockwise rotation by th
        z = cz[:, None] - s * vx[:, None] + c * vz[:, None]
        return np.stack([x, z, rho0[:, None] - th], axis=-1)

    def swept_volume(self, poses: np.ndarray, surface: SurfaceProfile) -> float:
        """Soil a tip path (S, 3) sweeps between the mapped surface and itself, times the bucket width [m^3]."""
        return float(self._swept(poses, surface).sum())

    # -- per-sample quantities ------------------------------------------------------------------
    def _swept(self, poses: np.ndarray, surface: SurfaceProfile) -> np.ndarray:
        """Volume swept between consecutive samples [m^3] (..., S-1): depth x travel x width."""
        xm = 0.5 * (poses[..., 1:, 0] + poses[..., :-1, 0])
        zm = 0.5 * (poses[..., 1:, 1] + poses[..., :-1, 1])
        dx = poses[..., :-1, 0] - poses[..., 1:, 0]
        return np.maximum(surface(xm) - zm, 0.0) * np.abs(dx) * self.width

    def _ik(self, poses: np.ndarray, wrench: np.ndarray | None = None, payload: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Compiled IK (and static torques when ``wrench`` is given) of flat poses (n, 3)."""
        n = poses.shape[0]
        q = np.empty((n, 3))
        ok = np.empty(n, bool)
        tau = np.empty((n, 3))
        want = wrench is not None
        ik_torques(self._arm_params, np.ascontiguousarray(poses, dtype=float),
                   np.ascontiguousarray(wrench) if want else np.zeros((n, 3)),
                   np.ascontiguousarray(payload) if want else np.zeros(n), self._load_tip, want, q, ok, tau)
        return q, ok, tau

    def _reach(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Reachability (table, then exact IK on the table's survivors) and joint angles."""
        flat = poses.reshape(-1, 3)
        ok = self.table.contains(flat)
        q = np.full(flat.shape, np.nan)
        if ok.any():
            qi, oki, _ = self._ik(flat[ok])
            q[ok] = qi
            ok[ok] = oki
        return ok.reshape(poses.shape[:-1]), q.reshape(poses.shape)

    def _torque_ratio(self, poses: np.ndarray, depth: np.ndarray, volume: np.ndarray,
                      progress: np.ndarray | None = None, surface: SurfaceProfile | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted forces, static joint torques (eq. 28) and the largest torque/limit ratio per
        sample; ``inf`` ratio where a pose is unreachable. ``progress`` (..., 4) and ``surface``
        reach the predictor in its :class:`DigContext` (see :func:`trajectory_progress`)."""
        f = self.predictor.predict(depth, poses[..., 2], volume, DigContext(poses, progress, surface))
        shape = poses.shape[:-1]
        wrench = np.concatenate([f.reshape(-1, 2), np.zeros((f[..., 0].size, 1))], axis=-1)
        _, ok, tau = self._ik(poses.reshape(-1, 3), wrench, (self.density * volume).reshape(-1))
        ratio = np.where(ok, np.max(np.abs(tau) / self.limits, axis=-1), np.inf)
        return f, tau.reshape(shape + (3,)), ratio.reshape(shape)

    # -- the search -----------------------------------------------------------------------------
    def plan(self, emap: ElevationMap, *, prune: bool = True, classify_limits: bool = False) -> PlanResult:
        """Choose one dig on ``emap`` by exhaustive search over the grid (see the module docstring).

        Args:
            classify_limits: also search once more with the force constraint off, so that
                ``limiting`` tells geometry-limited cells (1) from force-limited ones (2, feasible
                but for force: Fig. 87). Without it, every infeasible cell is marked 1.
            emap: the scanned elevation map (never the true terrain).
            prune: skip cells beyond the first goal-cutting penetration along d1 and evaluate
                constraints cheapest first on survivors only; ``False`` evaluates every constraint
                on every cell (same answer, for tests and figures).
        """
        t0 = time.perf_counter()
        cfg = self.cfg
        surface = SurfaceProfile.from_map(emap, self.arm, math.radians(self.goal.waist_deg), self.width)
        kk, aa, dd = np.meshgrid(self.grid_k, self.grid_alpha, self.grid_d1, indexing="ij")
        k, alpha, d1 = kk.ravel(), aa.ravel(), dd.ravel()
        n = k.size
        shape = self.grid_shape
        vmax = cfg.fill_fraction * self.capacity
        tol_shape, tol_surf = cfg.shaping_tolerance_m, cfg.surface_tolerance_m
        counts = {"cells": n}

        # Penetration: shaping and sensible on every cell (cheap), then prune along d1.
        pen = self.penetrate(k, alpha, d1, surface)
        pen_shape = np.all(pen[..., 1] >= goal_profile(self.goal, pen[..., 0]) - tol_shape, axis=1)
        pen_sense = np.all(pen[..., 1] <= surface(pen[..., 0]) + tol_surf, axis=1)
        if prune:
            ok3 = pen_shape.reshape(shape)
            alive = np.cumprod(ok3, axis=2).astype(bool).ravel()  # stop at the first failure along d1
        else:
            alive = np.ones(n, bool)
        counts["pruned_d1"] = int(n - alive.sum())

        drag_all = self.drag(pen[:, -1])
        n_j = drag_all.shape[1]
        res_j = np.full(n, _NO_DIG)
        res_r = np.zeros(n)
        res = {key: np.full(n, np.nan) for key in ("volume", "peak", "cum")}
        masks = {c: np.zeros(n, bool) for c in CONSTRAINTS}
        limiting = np.ones(n, np.int8)  # 0 feasible, 1 geometry (or unclassified), 2 force
        evaluated = 0

        idx = np.nonzero(alive)[0]
        if idx.size:
            evaluated = idx.size
            info = self._penetrations(k, alpha, d1, surface)
            sub = {key: (v[idx] if isinstance(v, np.ndarray) else v) for key, v in info.items()}
            out = self._evaluate(idx, pen[idx], drag_all[idx], surface, vmax, prune, sub)
            res_j[idx], res_r[idx] = out["j"], out["r"]
            for key in res:
                res[key][idx] = out[key]
            for c in CONSTRAINTS:
                masks[c][idx] = out["mask_" + c]
            limiting[idx] = np.where(out["j"] >= 0, 0, 1)
            if classify_limits:
                saved = self.limits
                self.limits = np.full(3, np.inf)
                try:
                    free = self._evaluate(idx, pen[idx], drag_all[idx], surface, vmax, prune)
                finally:
                    self.limits = saved
                limiting[idx] = np.where(out["j"] >= 0, 0, np.where(free["j"] >= 0, 2, 1))
        counts["evaluated"] = evaluated
        counts.update({k_: int(v) for k_, v in (out.get("stage_counts", {}) if idx.size else {}).items()})
        feasible = res_j >= 0
        # Mask of the penetration constraints on every cell (pruned cells failed shaping).
        masks["shaping"] &= pen_shape
        masks["sensible"] &= pen_sense

        choice, utility, reason = self._choose(feasible, res)
        action = None
        poses = np.zeros((0, 3))
        phases = np.zeros(0, np.int8)
        forces = np.zeros((0, 2))
        torques = np.zeros((0, 3))
        vol = 0.0
        if choice is not None:
            c = choice
            j = int(res_j[c])
            action = (float(k[c]), float(alpha[c]), float(d1[c]), j * cfg.sample_spacing_m)
            poses, phases = self.trajectory(action, surface, radius=float(res_r[c]))
            steps = self._swept(poses, surface)
            vcum = np.concatenate([[0.0], np.cumsum(steps)])
            depth = np.maximum(surface(poses[:, 0]) - poses[:, 1], 0.0)
            prog = trajectory_progress(poses, phases, self._eps)
            forces, torques, _ = self._torque_ratio(poses, depth, vcum, prog, surface)
            vol = float(res["volume"][c])
        return PlanResult(
            action=action, reason=reason, utility=utility, volume_m3=vol, poses=poses, phases=phases, forces=forces,
            torques=torques, grid_k=self.grid_k, grid_alpha=self.grid_alpha, grid_d1=self.grid_d1,
            feasible=feasible.reshape(shape), d2=np.where(feasible, res_j * cfg.sample_spacing_m, np.nan).reshape(shape),
            volume=res["volume"].reshape(shape), peak_torque_ratio=res["peak"].reshape(shape),
            cumulative_torque=res["cum"].reshape(shape), limiting=limiting.reshape(shape),
            masks={c: m.reshape(shape) for c, m in masks.items()}, counts=counts,
            seconds=time.perf_counter() - t0,
        )

    def trajectory(self, action: tuple[float, float, float, float], surface: SurfaceProfile,
                   radius: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Poses (S, 3) and phase labels (0 penetrate, 1 drag, 2 curl) of one action."""
        k, alpha, d1, d2 = action
        ds = self.cfg.sample_spacing_m
        n_p = int(math.ceil(d1 / ds)) + 1
        s = np.linspace(0.0, d1, n_p)
        z0 = float(surface(np.array([k]))[0])
        rho_p = alpha + math.radians(self.cfg.epsilon_deg)
        pen = np.stack([k - s * math.cos(alpha), z0 - s * math.sin(alpha), np.full(n_p, rho_p)], axis=-1)
        n_d = int(round(d2 / ds)) + 1
        sd = np.arange(n_d) * ds
        drag = np.stack([pen[-1, 0] - sd, np.full(n_d, pen[-1, 1]),
                         np.maximum(math.radians(self.cfg.zeta_deg),
                                    rho_p - math.radians(self.cfg.omega_deg_per_m) * sd)], axis=-1)
        if radius is None:  # the smallest radius whose end pose is reachable, as in the search
            ends = np.concatenate([self.curl(drag[-1:], np.array([r_]))[:, -1] for r_ in self.cfg.curl_radii_m])
            ok, _ = self._reach(ends[:, None, :])
            radius = self.cfg.curl_radii_m[int(np.argmax(ok[:, 0]))] if ok.any() else self.cfg.curl_radii_m[0]
        curl = self.curl(drag[-1:], np.array([radius]))[0]
        poses = np.concatenate([pen, drag[1:], curl[1:]])
        phases = np.concatenate([np.zeros(n_p), np.ones(n_d - 1), np.full(len(curl) - 1, 2)]).astype(np.int8)
        return poses, phases

    def check_action(self, emap: ElevationMap, action: tuple[float, float, float, float],
                     radius: float | None = None) -> dict[str, bool]:
        """Each constraint's verdict on one fully specified dig (k, alpha, d1, d2), plus its volume.

        The same tests as the search, on the whole path of this one action: for inspecting a dig,
        and for the executor to re-check a plan against a fresh map.
        """
        cfg = self.cfg
        surface = SurfaceProfile.from_map(emap, self.arm, math.radians(self.goal.waist_deg), self.width)
        poses, phases = self.trajectory(action, surface, radius)
        body = phases < 2
        curl = poses[phases == 2]
        shaping = bool(np.all(poses[:, 1] >= goal_profile(self.goal, poses[:, 0]) - cfg.shaping_tolerance_m))
        in_soil = poses[body, 1] <= surface(poses[body, 0]) + cfg.surface_tolerance_m
        above = curl[:, 1] > surface(curl[:, 0]) + cfg.surface_tolerance_m
        exit_ok = (not above.any()) or curl[int(np.argmax(above)), 2] <= math.radians(cfg.curl_exit_pitch_deg)
        vcum = np.concatenate([[0.0], np.cumsum(self._swept(poses, surface))])
        reach, _ = self._reach(poses[None])
        reachable = bool(reach.all())
        force = False
        if reachable:
            depth = np.maximum(surface(poses[:, 0]) - poses[:, 1], 0.0)
            prog = trajectory_progress(poses, phases, self._eps)
            _, _, ratio = self._torque_ratio(poses, depth, vcum, prog, surface)
            force = bool(ratio.max() <= 1.0)
        return {"shaping": shaping, "sensible": bool(in_soil.all() and exit_ok),
                "volume": bool(vcum[-1] <= cfg.fill_fraction * self.capacity), "reachability": reachable,
                "force": force, "volume_m3": float(vcum[-1])}

    def _penetration_verdicts(self, pen: np.ndarray, surface: SurfaceProfile, prune: bool) -> dict:
        """Shaping, sensible, reachability, force, volume and torque sums of penetrations (m, P, 3)."""
        cfg = self.cfg
        m = pen.shape[0]
        shape = np.all(pen[..., 1] >= goal_profile(self.goal, pen[..., 0]) - cfg.shaping_tolerance_m, axis=1)
        sense = np.all(pen[..., 1] <= surface(pen[..., 0]) + cfg.surface_tolerance_m, axis=1)
        steps = self._swept(pen, surface)
        reach = self._reach(pen)[0].all(axis=1)
        vcum = np.concatenate([np.zeros((m, 1)), np.cumsum(steps, axis=1)], axis=1)
        depth = np.maximum(surface(pen[..., 0]) - pen[..., 1], 0.0)
        peak = np.full(m, np.inf)
        cum = np.zeros(m)
        sel = reach if prune else np.ones(m, bool)
        if sel.any():
            _, tau, ratio = self._torque_ratio(pen[sel], depth[sel], vcum[sel],
                                               trajectory_progress(pen[sel], 0, self._eps), surface)
            peak[sel] = ratio.max(axis=1)
            cum[sel] = (np.nan_to_num(np.abs(tau)).sum(axis=-1)[:, 1:] * self._step_len(pen[sel])).sum(axis=1)
        return {"shape": shape, "sense": sense, "reach": reach, "force": peak <= 1.0, "peak": peak, "cum": cum,
                "volume": steps.sum(axis=1), "samples": int(pen.shape[0] * pen.shape[1])}

    def _penetrations(self, k: np.ndarray, alpha: np.ndarray, d1: np.ndarray, surface: SurfaceProfile) -> dict:
        """Penetration verdicts for the whole grid, sharing the work along each (k, alpha) line.

        Every penetration of a (k, alpha) pair lies on one line from the entry point; its samples at
        multiples of the spacing are evaluated once per line and each cell adds only its end point
        (prefix AND / max / sum over the line's samples before d1).
        """
        nk, na, nd = self.grid_shape
        ds = self.cfg.sample_spacing_m
        n_s = int(math.ceil(self.grid_d1.max() / ds)) + 1
        kl = np.repeat(self.grid_k, na)
        al = np.tile(self.grid_alpha, nk)
        line = self.penetrate(kl, al, np.full(kl.size, (n_s - 1) * ds), surface)  # (L, n_s, 3), unclamped
        cfg = self.cfg
        shape_i = line[..., 1] >= goal_profile(self.goal, line[..., 0]) - cfg.shaping_tolerance_m
        sense_i = line[..., 1] <= surface(line[..., 0]) + cfg.surface_tolerance_m
        steps = self._swept(line, surface)
        vcum = np.concatenate([np.zeros((line.shape[0], 1)), np.cumsum(steps, axis=1)], axis=1)
        reach_i = self._reach(line)[0]
        depth = np.maximum(surface(line[..., 0]) - line[..., 1], 0.0)
        _, tau, ratio = self._torque_ratio(line, depth, vcum, trajectory_progress(line, 0, self._eps), surface)
        tsum = np.nan_to_num(np.abs(tau)).sum(axis=-1)
        cum_i = np.concatenate([np.zeros((line.shape[0], 1)), np.cumsum(tsum[:, 1:] * ds, axis=1)], axis=1)
        # per cell: line samples 0 .. c-1 lie before d1, then the end point at d1
        li = np.arange(nk * na).repeat(nd)
        c = np.clip(np.ceil(d1 / ds - 1e-9).astype(np.int64), 1, n_s)
        last = c - 1
        cumall = lambda ok: np.cumprod(ok, axis=1).astype(bool)  # noqa: E731
        end = np.stack([k - d1 * np.cos(alpha), surface(k) - d1 * np.sin(alpha),
                        alpha + math.radians(cfg.epsilon_deg)], axis=-1)
        prev = line[li, last]
        seg = np.stack([prev, end], axis=1)
        v_end = vcum[li, last] + self._swept(seg, surface)[:, 0]
        end_reach = self._reach(end[:, None, :])[0][:, 0]
        _, tau_e, ratio_e = self._torque_ratio(end, np.maximum(surface(end[:, 0]) - end[:, 1], 0.0), v_end,
                                               np.stack([k, alpha, d1, np.zeros_like(d1)], axis=-1), surface)
        peak_line = np.maximum.accumulate(np.where(np.isfinite(ratio), ratio, np.inf), axis=1)
        shape = cumall(shape_i)[li, last] & (end[:, 1] >= goal_profile(self.goal, end[:, 0]) - cfg.shaping_tolerance_m)
        sense = cumall(sense_i)[li, last] & (end[:, 1] <= surface(end[:, 0]) + cfg.surface_tolerance_m)
        reach = cumall(reach_i)[li, last] & end_reach
        peak = np.where(reach, np.maximum(peak_line[li, last], ratio_e), np.inf)
        seg_len = np.linalg.norm(end[:, :2] - prev[:, :2], axis=1)
        cum = cum_i[li, last] + np.nan_to_num(np.abs(tau_e)).sum(axis=-1) * seg_len
        return {"shape": shape, "sense": sense, "reach": reach, "force": peak <= 1.0, "peak": peak, "cum": cum,
                "volume": v_end, "samples": int(line.shape[0] * n_s + k.size)}

    def _evaluate(self, idx, pen, drag, surface, vmax, prune, pen_info: dict | None = None) -> dict:
        """Constraints and the longest admissible drag for the cells ``idx`` (vectorized).

        ``pen_info`` (from :meth:`_penetrations`) supplies the penetration's verdicts, computed once
        per (k, alpha) line; without it they are computed here from ``pen``.
        """
        cfg = self.cfg
        m, n_j = drag.shape[:2]
        tol_shape, tol_surf = cfg.shaping_tolerance_m, cfg.surface_tolerance_m
        stage = {}
        if pen_info is None:
            pen_info = self._penetration_verdicts(pen, surface, prune)
        p_shape, p_sense, v_pen = pen_info["shape"], pen_info["sense"], pen_info["volume"]
        p_reach, p_force = pen_info["reach"], pen_info["force"]
        peak_p, cum_p = pen_info["peak"], pen_info["cum"]
        # Drag prefixes: count of leading samples passing each cheap constraint.
        d_shape = drag[..., 1] >= goal_profile(self.goal, drag[..., 0]) - tol_shape
        d_sense = drag[..., 1] <= surface(drag[..., 0]) + tol_surf
        v_drag = np.concatenate([np.zeros((m, 1)), np.cumsum(self._swept(drag, surface), axis=1)], axis=1)
        v_cum = v_pen[:, None] + v_drag
        d_vol = v_cum <= vmax
        lead = lambda ok: np.argmin(np.concatenate([ok, np.zeros((m, 1), bool)], axis=1), axis=1)  # noqa: E731
        j_shape, j_sense, j_vol = lead(d_shape), lead(d_sense), lead(d_vol)
        j_geo = np.minimum(np.minimum(j_shape, j_sense), j_vol)
        j_geo = np.where(p_shape & p_sense, j_geo, 0) if prune else np.full(m, n_j)
        # Reachability on penetrate + drag samples (only up to j_geo when pruning).
        live = np.arange(n_j)[None, :] < np.maximum(j_geo, 1)[:, None] if prune else np.ones((m, n_j), bool)
        d_reach = np.zeros((m, n_j), bool)
        sel = live & (p_reach[:, None] | (not prune))
        stage["reach_samples"] = int(sel.sum()) + pen_info["samples"]
        if sel.any():
            d_reach[sel] = self._reach(drag[sel])[0]
        j_reach = lead(d_reach)
        # Force on the drag samples that are geometrically live.
        j_live = np.minimum(j_geo, j_reach) if prune else np.full(m, n_j)
        fsel = (np.arange(n_j)[None, :] < np.maximum(j_live, 1)[:, None]) & p_force[:, None] if prune else \
            np.ones((m, n_j), bool)
        ratio_d = np.full((m, n_j), np.inf)
        absum_d = np.zeros((m, n_j))
        stage["force_samples"] = int(fsel.sum()) + pen_info["samples"]
        prog_d = trajectory_progress(drag, 1, self._eps, start=trajectory_progress(pen, 0, self._eps)[:, -1])
        if fsel.any():
            depth_d = np.maximum(surface(drag[..., 0]) - drag[..., 1], 0.0)
            _, tau, ratio = self._torque_ratio(drag[fsel], depth_d[fsel], v_cum[fsel], prog_d[fsel], surface)
            ratio_d[fsel] = ratio
            absum_d[fsel] = np.nan_to_num(np.abs(tau)).sum(axis=-1)
        d_force = ratio_d <= 1.0
        j_force = lead(d_force)
        # The longest drag whose curl also passes. Feasibility is not monotone in d2 (a short drag
        # leaves the rake too high to curl before the edge leaves the soil; a long one runs the curl
        # into the near wall), so scan down from the prefix bound in strides, then refine upward.
        j_all = np.minimum(np.minimum(j_shape, j_sense), np.minimum(j_vol, np.minimum(j_reach, j_force)))
        pen_ok = p_shape & p_sense & p_reach & p_force
        best_j = np.full(m, _NO_DIG)
        best_r = np.zeros(m)
        res_curl = {key: np.full(m, np.nan) for key in ("volume", "peak", "cum")}
        stage["curl_evaluations"] = 0

        def try_curl(cells: np.ndarray, jj: np.ndarray) -> np.ndarray:
            stage["curl_evaluations"] += len(cells)
            ok, r, extra = self._curl_ok(drag[cells, jj], surface, v_cum[cells, jj], vmax, prog_d[cells, jj])
            better = ok & (jj > best_j[cells])
            win = cells[better]
            best_j[win] = jj[better]
            best_r[win] = r[better]
            for key, v in extra.items():
                res_curl[key][win] = v[better]
            return ok

        hi = j_all - 1
        stride = _CURL_STRIDE
        for t in range(int(math.ceil(n_j / stride)) + 1):
            jj = hi - stride * t
            todo = np.nonzero(pen_ok & (jj >= 0) & (best_j == _NO_DIG))[0]
            if todo.size == 0:
                break
            try_curl(todo, jj[todo])
        for up in range(stride - 1, 0, -1):  # refine: the largest j in (found, found + stride)
            jj = np.minimum(best_j + up, hi)
            todo = np.nonzero((best_j >= 0) & (jj > best_j))[0]
            if todo.size:
                try_curl(todo, jj[todo])
        # Per-cell results.
        feasible = best_j >= 0
        jsafe = np.maximum(best_j, 0)
        rows = np.arange(m)
        volume = np.where(feasible, v_cum[rows, jsafe] + res_curl["volume"], np.nan)
        prefix_peak = np.maximum.accumulate(np.where(np.isfinite(ratio_d), ratio_d, np.inf), axis=1)
        peak = np.where(feasible, np.maximum(np.maximum(peak_p, prefix_peak[rows, jsafe]),
                                             res_curl["peak"]), np.nan)
        ds = cfg.sample_spacing_m
        cum_d = np.cumsum(absum_d * ds, axis=1) - absum_d[:, :1] * ds
        cum = np.where(feasible, cum_p + cum_d[rows, jsafe] + res_curl["cum"], np.nan)
        # Per-constraint masks at the shortest drag (j = 0), and which kind of constraint limits.
        geo0 = d_shape[:, 0] & d_sense[:, 0] & d_vol[:, 0]
        return {
            "j": best_j, "r": best_r, "volume": volume, "peak": peak, "cum": cum,
            "mask_shaping": p_shape & d_shape[:, 0], "mask_sensible": p_sense & d_sense[:, 0],
            "mask_volume": d_vol[:, 0], "mask_reachability": p_reach & d_reach[:, 0] if not prune else p_reach,
            "mask_force": p_force & (d_force[:, 0] | ~geo0), "stage_counts": stage,
            "prefix": np.stack([j_shape, j_sense, j_vol, j_reach, j_force]), "pen_ok": pen_ok,
        }

    @staticmethod
    def _step_len(poses: np.ndarray) -> np.ndarray:
        return np.linalg.norm(np.diff(poses[..., :2], axis=-2), axis=-1)

    def _curl_ok(self, start: np.ndarray, surface: SurfaceProfile, v_before: np.ndarray, vmax: float,
                 progress: np.ndarray | None = None):
        """Smallest reachable curl radius per start pose and whether that curl passes every constraint."""
        cfg = self.cfg
        n = start.shape[0]
        radius = np.full(n, np.nan)
        for r in cfg.curl_radii_m:  # smallest radius whose end pose is reachable (Fig. 23)
            todo = np.isnan(radius)
            if not todo.any():
                break
            end = self.curl(start[todo], np.full(todo.sum(), r))[:, -1]
            ok, _ = self._reach(end[:, None, :])
            sel = np.nonzero(todo)[0][ok[:, 0]]
            radius[sel] = r
        has = np.isfinite(radius)
        ok = has.copy()
        extra = {"volume": np.zeros(n), "peak": np.zeros(n), "cum": np.zeros(n)}
        if not has.any():
            return ok, np.nan_to_num(radius), extra
        h = np.nonzero(has)[0]
        poses = self.curl(start[h], radius[h])
        shape_ok = np.all(poses[..., 1] >= goal_profile(self.goal, poses[..., 0]) - cfg.shaping_tolerance_m, axis=1)
        # Sensible (§4.3.6): the bucket must have curled enough to hold its load before the edge
        # leaves the soil; what follows the exit is the lift-out.
        above = poses[..., 1] > surface(poses[..., 0]) + cfg.surface_tolerance_m
        exits = above.any(axis=1)
        first = np.argmax(above, axis=1)
        exit_pitch = poses[np.arange(len(h)), first, 2]
        sense_ok = ~exits | (exit_pitch <= math.radians(cfg.curl_exit_pitch_deg))
        steps = self._swept(poses, surface)
        vol = v_before[h][:, None] + np.concatenate([np.zeros((len(h), 1)), np.cumsum(steps, axis=1)], axis=1)
        vol_ok = vol[:, -1] <= vmax
        reach_ok, _ = self._reach(poses)
        reach_ok = reach_ok.all(axis=1)
        depth = np.maximum(surface(poses[..., 0]) - poses[..., 1], 0.0)
        prog = None if progress is None else trajectory_progress(poses, 2, self._eps, start=progress[h])
        _, tau, ratio = self._torque_ratio(poses, depth, vol, prog, surface)
        force_ok = ratio.max(axis=1) <= 1.0
        ok[h] = shape_ok & sense_ok & vol_ok & reach_ok & force_ok
        extra["volume"][h] = vol[:, -1] - v_before[h]
        extra["peak"][h] = ratio.max(axis=1)
        extra["cum"][h] = (np.nan_to_num(np.abs(tau)).sum(axis=-1)[:, 1:] * self._step_len(poses)).sum(axis=1)
        return ok, np.nan_to_num(radius), extra

    def _choose(self, feasible: np.ndarray, res: dict) -> tuple[int | None, float, str]:
        """Apply the objective to the feasible cells: (index, utility, reason)."""
        cfg = self.cfg
        if not feasible.any():
            return None, 0.0, "no feasible dig"
        vol = np.where(feasible, res["volume"], -np.inf)
        useful = vol >= cfg.min_volume_fraction * self.capacity
        if not useful.any():
            return None, float(vol.max()), (f"best dig sweeps {1000 * vol.max():.1f} l, below the minimum "
                                            f"{100 * cfg.min_volume_fraction:.0f} % of capacity")
        peak = np.where(useful, res["peak"], np.inf)
        cum = np.where(useful, res["cum"], np.inf)
        if cfg.objective == "volume":
            c = int(np.argmax(vol))
            return c, float(vol[c]), "max volume"
        if cfg.objective == "peak_torque":
            c = int(np.argmin(peak))
            return c, float(-peak[c]), "min peak torque"
        if cfg.objective == "cumulative_torque":
            c = int(np.argmin(cum))
            return c, float(-cum[c]), "min cumulative torque"
        enough = vol >= cfg.volume_threshold * self.capacity  # eq. 44
        if enough.any():
            c = int(np.argmin(np.where(enough, peak, np.inf)))
            return c, float(1.0 - peak[c]), f"volume >= {100 * cfg.volume_threshold:.0f} % of capacity, min peak torque"
        c = int(np.argmax(vol))
        return c, 0.0, f"no dig reaches {100 * cfg.volume_threshold:.0f} % of capacity: max volume"


def _steps(lo: float, hi: float, step: float) -> np.ndarray:
    n = int(math.floor((hi - lo) / step + 1e-9)) + 1
    return lo + step * np.arange(n)
