"""Boundary-following fallback digs (Singh 1995 §7.2).

When the planner finds no dig of minimum utility, the thesis executes "a pre-planned set of
actions": for trenching, the robot follows the boundaries of the trench. Here that set is built from
the goal profile alone, offset up by ``fallback_clearance_m`` so that no dig cuts below the goal:

* **far wall**: enter at the top of the far wall, follow it down (rake = wall angle + epsilon, as a
  penetration, §3.4.2.2), then drag along the bottom with the rake of eq. 1, then curl;
  where the arm cannot hold that rake (far from the robot the T3's wrist holds the bucket no
  flatter than about 50 deg at 2.7 m), the rake is the smallest one it can hold, there and at the
  touch-down search below (:func:`reachable_rake`):
  a larger rake only lifts the bucket's bottom further off the path, so the bucket still never
  cuts below it, and without it the far wall of a 30-deg trench end is out of reach;
* **near wall**: drag along the bottom and rise up the near wall, the pitch turning to the curl's
  end pitch at the top, so the bucket leaves the soil curled;
* **bottom**: windows of the bottom drag that start every ``fallback_bottom_step_m`` from the far
  corner, each followed by a curl.

Each candidate keeps only its samples from the first one in the mapped soil and stops where the
swept volume would exceed ``fill_fraction`` x capacity. The set is tried in that order (walls, then
the bottom, each bottom window by its swept volume); the first candidate that sweeps at least
``fallback_min_volume_fraction`` of the capacity and passes the planner's shaping (its curl too),
reachability and force constraints is the dig. A candidate that fails is shortened, two samples at
a time, before it is given up. No optimization: these are the thesis' pre-planned digs, checked, not chosen.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from excavsim.handoff.goal import SurfaceProfile
from excavsim.handoff.maps import ElevationMap
from excavsim.planning.action import running_total, soil_depth
from excavsim.planning.constraints import force, sensible, shaping, touchdown, volume
from excavsim.planning.search import TrenchPlanner


@dataclasses.dataclass
class FallbackDig:
    """One boundary-following dig: its path, its label and its verdicts."""

    label: str
    poses: np.ndarray
    phases: np.ndarray
    volume_m3: float
    peak_torque_ratio: float
    reachable: bool
    shaping: bool
    seconds: float = 0.0
    peak_torques_nm: np.ndarray = dataclasses.field(default_factory=lambda: np.full(3, np.nan))

    @property
    def feasible(self) -> bool:
        """Within the goal (the curl included), reachable and within the torque limits."""
        return self.shaping and self.reachable and bool(force(self.peak_torque_ratio))


def boundary_polyline(planner: TrenchPlanner) -> tuple[np.ndarray, np.ndarray]:
    """Samples (N, 3) of (x, z, pitch) along the goal's boundary from the far top to the near top,
    ``clearance`` above it, and the index of each corner (far bottom, near bottom)."""
    g, cfg = planner.goal, planner.cfg
    c = cfg.fallback_clearance_m
    ds = cfg.sample_spacing_m
    top, bottom = g.surface_z_m + c, g.surface_z_m - g.depth_m + c
    far_run = (g.depth_m) / math.tan(math.radians(g.far_wall_deg))
    near_run = (g.depth_m) / math.tan(math.radians(g.near_wall_deg))
    corners = np.array([[g.far_x_m, top], [g.far_x_m - far_run, bottom], [g.near_x_m + near_run, bottom],
                        [g.near_x_m, top]])
    pts, idx = [corners[:1]], []
    for a, b in zip(corners[:-1], corners[1:]):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / ds)))
        t = np.arange(1, n + 1) / n
        pts.append(a + t[:, None] * (b - a))
        idx.append(sum(len(p) for p in pts) - 1)
    xz = np.concatenate(pts)
    i_far, i_near = idx[0], idx[1]
    eps, zeta = math.radians(cfg.epsilon_deg), math.radians(cfg.zeta_deg)
    pitch = np.empty(len(xz))
    pitch[: i_far + 1] = math.radians(g.far_wall_deg) + eps
    s = np.linalg.norm(xz[i_far:i_near + 1] - xz[i_far], axis=1)
    pitch[i_far:i_near + 1] = np.maximum(zeta, pitch[0] - math.radians(cfg.omega_deg_per_m) * s)
    end = math.radians(cfg.curl_end_pitch_deg)
    pitch[: i_near + 1] = reachable_rake(planner, xz[: i_near + 1], pitch[: i_near + 1])
    rise = np.linspace(0.0, 1.0, len(xz) - i_near)
    pitch[i_near:] = pitch[i_near] + rise * (end - pitch[i_near])
    return np.column_stack([xz, pitch]), np.array([i_far, i_near])


def reachable_rake(planner: TrenchPlanner, xz: np.ndarray, rake: np.ndarray, *, step_deg: float = 1.0,
                   max_deg: float = 90.0) -> np.ndarray:
    """(n,) ``rake`` (n,) [rad] at the tip positions ``xz`` (n, 2), raised where the arm cannot hold it
    to the smallest rake, in ``step_deg`` steps up to ``max_deg``, that it can hold there and
    ``touchdown_reach_m`` below (so that a dig entering at the sample can search for the soil below
    the map); unchanged where none is (the reachability constraint then refuses the sample)."""
    rake = np.asarray(rake, dtype=float).copy()
    below = np.array([0.0, planner.cfg.touchdown_reach_m])

    def holds(x: np.ndarray, z: np.ndarray, r: np.ndarray) -> np.ndarray:
        return np.all([planner.reach(np.stack([x, z - dz, r], axis=-1))[0] for dz in below], axis=0)

    bad = np.nonzero(~holds(xz[:, 0], xz[:, 1], rake))[0]
    if bad.size == 0:
        return rake
    cand = rake[bad, None] + np.radians(np.arange(0.0, max_deg + 1e-9, step_deg))[None, :]
    cand = np.minimum(cand, math.radians(max_deg))
    ok = holds(np.broadcast_to(xz[bad, None, 0], cand.shape), np.broadcast_to(xz[bad, None, 1], cand.shape), cand)
    found = ok.any(axis=1)
    rake[bad[found]] = cand[found, np.argmax(ok, axis=1)[found]]
    return rake
    tries = np.radians(np.arange(0.0, max_deg + 1e-9, step_deg))
    cand = rake[bad, None] + tries[None, :]
    cand = np.where(cand <= math.radians(max_deg) + 1e-12, cand, np.nan)
    grid = np.stack([np.broadcast_to(xz[bad, None, 0], cand.shape), np.broadcast_to(xz[bad, None, 1], cand.shape),
                     np.nan_to_num(cand, nan=rake[bad, None].repeat(cand.shape[1], 1))], axis=-1)
    reach, _ = planner.reach(grid)
    reach &= np.isfinite(cand)
    first = np.argmax(reach, axis=1)
    found = reach.any(axis=1)
    rake[bad[found]] = cand[found, first[found]]
    return rake


def _with_curl(planner: TrenchPlanner, path: np.ndarray, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Append the curl with the smallest reachable radius (Fig. 23), unless already curled."""
    if path[-1, 2] <= math.radians(planner.cfg.curl_end_pitch_deg) + 1e-9:
        return path, phases
    r = planner.curl_radius(path[-1:], default=planner.cfg.curl_radii_m[0])
    curl = planner.curl(path[-1:], r)[0][1:]
    return np.concatenate([path, curl]), np.concatenate([phases, np.full(len(curl), 2, np.int8)])


def candidates(planner: TrenchPlanner, emap: ElevationMap) -> list[FallbackDig]:
    """The pre-planned boundary digs on this map, in the order they are tried (see the module docstring)."""
    cfg = planner.cfg
    surface = planner.surface(emap)
    line, (i_far, i_near) = boundary_polyline(planner)
    phase = np.where(np.arange(len(line)) < i_far, 0, 1).astype(np.int8)
    vmax = cfg.volume_limit_m3(planner.capacity)
    soil = sensible(line, surface, cfg.surface_tolerance_m)
    seg = np.concatenate([[0.0], planner.swept(line, surface)])  # volume swept reaching sample i

    vmin = cfg.fallback_min_volume_fraction * planner.capacity
    stride = 2

    def window(a: int, b: int, label: str, *, keep_end: bool = False) -> FallbackDig | None:
        """The longest part of line[a..b] (shortened from its start when ``keep_end``, else from its
        end) that starts in the soil, fits the bucket and passes reachability and force."""
        ins = np.nonzero(soil[a:b + 1])[0]
        if ins.size == 0:
            return None
        a = a + int(ins[0])
        if keep_end:
            back = np.cumsum(seg[a + 1:b + 1][::-1])[::-1]  # volume from sample a + i to b
            fits = volume(back, vmax)
            a = a + int(np.argmax(fits)) if fits.any() else b
            tries = [(a_, b) for a_ in range(a, b, stride)]
        else:
            vol = np.cumsum(seg[a + 1:b + 1])
            b = a + int(np.searchsorted(vol, vmax, side="right"))
            tries = [(a, b_) for b_ in range(b, a, -stride)]
        last = None
        for a_, b_ in tries:
            if not soil[a_]:
                continue
            path, ph = _with_curl(planner, line[a_:b_ + 1], phase[a_:b_ + 1])
            last = _verdict(planner, label, path, ph, surface)
            if last.volume_m3 < vmin or last.feasible:
                break  # feasible, or too small to matter: shorter ones are smaller still
        return last

    out = [d for d in (window(0, len(line) - 1, "far wall"),
                       window(i_far, len(line) - 1, "near wall", keep_end=True)) if d is not None]
    step = max(1, int(round(cfg.fallback_bottom_step_m / cfg.sample_spacing_m)))
    bottoms = [window(a, i_near, f"bottom from x {line[a, 0]:.2f} m") for a in range(i_far, i_near, step)]
    out += sorted((d for d in bottoms if d is not None), key=lambda d: -d.volume_m3)
    return out


def _verdict(planner: TrenchPlanner, label: str, poses: np.ndarray, phases: np.ndarray,
             surface: SurfaceProfile) -> FallbackDig:
    vcum = running_total(planner.swept(poses, surface))
    reach, _ = planner.reach(poses[None])
    reachable = bool(reach.all() and touchdown(poses[0], planner.statics, planner.cfg.touchdown_reach_m))
    peak = math.inf
    peaks = np.full(3, np.nan)
    if reachable:
        _, tau, ratio = planner.torque_ratio(poses, soil_depth(poses, surface), vcum)
        peak = float(ratio.max())
        peaks = np.abs(tau).max(axis=0)
    within = bool(np.all(shaping(poses, planner.goal, planner.cfg.shaping_tolerance_m)))
    return FallbackDig(label, poses, phases, float(vcum[-1]), peak, reachable, within, peak_torques_nm=peaks)


def choose_boundary(planner: TrenchPlanner, emap: ElevationMap, *,
                    skip: Callable[[FallbackDig], bool] | None = None) -> tuple[FallbackDig | None, str]:
    """The first feasible boundary dig of minimum volume, or None with the reason.

    Args:
        skip: a candidate for which it returns True is passed over (a boundary dig that failed
            before on the same terrain: :class:`~excavsim.planning.experience.DigExperience`).
    """
    t0 = time.perf_counter()
    cands = candidates(planner, emap)
    vmin = planner.cfg.fallback_min_volume_fraction * planner.capacity
    skipped = 0
    for dig in cands:
        if dig.feasible and dig.volume_m3 >= vmin:
            if skip is not None and skip(dig):
                skipped += 1
                continue
            dig.seconds = time.perf_counter() - t0
            return dig, f"boundary dig: {dig.label}"
    why = (f"none of {len(cands)} boundary digs stays within the goal, is reachable within the torque limits "
           f"and sweeps {1000 * vmin:.1f} l") if cands else "no soil left above the boundary path"
    if skipped:
        why += f" ({skipped} feasible ones failed before on the same terrain)"
    return None, why
