"""The trenching action's geometry (Singh 1995 §3.4): the tip path of a dig and the soil it sweeps.

One dig is the trenching action (k, alpha, d1, d2) of §3.4.1 (Fig. 14, Fig. 36): enter the mapped surface at
radial distance ``k``; **penetrate** a straight line at ``alpha`` below horizontal for ``d1`` with rake
``alpha + epsilon`` (§3.4.2.2); **drag** horizontally towards the robot for ``d2`` while the rake falls as
``max(zeta, rho_i - omega s)`` (§3.4.2.3, eq. 1); **curl** about a centre behind the heel and above the blade,
``r`` from the edge (Fig. 16's admissible region), turning the bucket to the end pitch, with the smallest
radius of ``curl_radii_m`` whose end pose is reachable (§3.4.2.4, Fig. 23).

Each phase is one vectorized function of the distances sampled along it, so that the search (samples every
``sample_spacing_m``, padded to the grid's longest penetration) and the path of one chosen action
(:func:`trajectory`, evenly spaced samples ending at ``d1``) are the same geometry. Poses are (x, z, pitch) of the
bucket tip in the arm plane [m, m, rad]; the swept volume is the area between the mapped surface and the path,
times the bucket width.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from excavsim.config import PlannerConfig
from excavsim.handoff.goal import SurfaceProfile

Reachable = Callable[[np.ndarray], np.ndarray]  # poses (..., 3) -> (...,) bool


def penetration_samples(d1_max: float, spacing: float) -> int:
    """Samples of the longest penetration ``d1_max`` [m] at ``spacing`` [m], both ends included."""
    return int(math.ceil(d1_max / spacing)) + 1


def padded_distances(length: np.ndarray, spacing: float, n: int) -> np.ndarray:
    """(m, n) distances 0, spacing, 2 spacing, ... along m paths, held at each ``length`` (m,) [m] once reached.

    The samples past a path's end repeat its end pose, so that paths of different lengths share one array.
    """
    return np.minimum(np.arange(n)[None, :] * spacing, length[:, None])


def penetrate(k: np.ndarray, alpha: np.ndarray, s: np.ndarray, surface: SurfaceProfile,
              cfg: PlannerConfig) -> np.ndarray:
    """(n, P, 3) penetrate poses of n actions: a straight line at ``alpha``, rake ``alpha + epsilon`` (§3.4.2.2).

    Args:
        k: (n,) entry distances [m]; the entry is on the mapped ``surface``.
        alpha: (n,) approach angles below horizontal [rad].
        s: (n, P) distances along each penetration [m] (see :func:`padded_distances`).
        surface: the mapped surface along the arm plane.
        cfg: the planner's rules (``epsilon_deg``).
    """
    x = k[:, None] - s * np.cos(alpha)[:, None]
    z = surface(k)[:, None] - s * np.sin(alpha)[:, None]
    rho = np.broadcast_to((alpha + math.radians(cfg.epsilon_deg))[:, None], x.shape)
    return np.stack([x, z, rho], axis=-1)


def drag(start: np.ndarray, s: np.ndarray, cfg: PlannerConfig) -> np.ndarray:
    """(n, J, 3) drag poses from penetrate end poses ``start`` (n, 3) at drag lengths ``s`` (J,) [m] (eq. 1).

    The tip moves horizontally towards the robot; the rake falls by ``omega`` per metre down to ``zeta``.
    """
    x = start[:, None, 0] - s[None, :]
    z = np.broadcast_to(start[:, None, 1], x.shape)
    rho = np.maximum(math.radians(cfg.zeta_deg), start[:, None, 2] - math.radians(cfg.omega_deg_per_m) * s[None, :])
    return np.stack([x, z, rho], axis=-1)


def curl(start: np.ndarray, radius: np.ndarray, cfg: PlannerConfig) -> np.ndarray:
    """(n, M, 3) curl poses from drag end poses ``start`` (n, 3) about centres ``radius`` (n,) [m] away (§3.4.2.4).

    The bucket turns clockwise in (x, z) to ``curl_end_pitch_deg`` about a centre ``radius`` from the edge
    along ``u = (b + z_t) / sqrt 2``, halfway between the blade's direction towards the heel
    ``b = (cos rho, sin rho)`` and its normal into the bucket ``z_t = (-sin rho, cos rho)``.
    Under that rotation a blade point ``s`` behind the edge moves along ``z_t`` at
    ``(r u.b - s) omega``: the bottom moves away from the soil (the admissible centres of
    Fig. 16) as long as ``r / sqrt 2`` exceeds the blade's length, hence radii from 0.35 m.
    A centre straight above the edge pressed the heel into the cut and stalled the wrist in
    the world.
    """
    rho0 = start[:, 2]
    turn = np.maximum(rho0 - math.radians(cfg.curl_end_pitch_deg), 0.0)
    frac = np.linspace(0.0, 1.0, cfg.curl_samples)
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


def curl_radius(start: np.ndarray, cfg: PlannerConfig, reachable: Reachable, *, default: float = math.nan
                ) -> np.ndarray:
    """(n,) the smallest radius of ``curl_radii_m`` whose curl from ``start`` (n, 3) ends at a reachable pose.

    The search of Fig. 23 (§3.4.2.4): try the radii from the smallest, keep the first whose end pose
    ``reachable`` accepts; ``default`` where none does.
    """
    radius = np.full(start.shape[0], np.nan)
    for r in cfg.curl_radii_m:
        todo = np.isnan(radius)
        if not todo.any():
            break
        end = curl(start[todo], np.full(todo.sum(), r), cfg)[:, -1]
        radius[np.nonzero(todo)[0][reachable(end[:, None, :])[:, 0]]] = r
    return np.where(np.isnan(radius), default, radius)


def trajectory(action: tuple[float, float, float, float], surface: SurfaceProfile, cfg: PlannerConfig, *,
               radius: float | None = None, reachable: Reachable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Poses (S, 3) and phase labels (S,) (0 penetrate, 1 drag, 2 curl) of one action (k, alpha, d1, d2).

    The penetration is sampled evenly from the entry to ``d1`` (at most ``sample_spacing_m`` apart), the
    drag every ``sample_spacing_m``. ``radius`` None curls with :func:`curl_radius` (``reachable`` then
    required), the smallest radius when none is reachable.
    """
    k, alpha, d1, d2 = action
    ds = cfg.sample_spacing_m
    n_p = penetration_samples(d1, ds)
    pen = penetrate(np.array([k], dtype=float), np.array([alpha], dtype=float),
                    np.linspace(0.0, d1, n_p)[None, :], surface, cfg)[0]
    n_d = int(round(d2 / ds)) + 1
    drg = drag(pen[-1:], np.arange(n_d) * ds, cfg)[0]
    if radius is None:
        radius = curl_radius(drg[-1:], cfg, reachable, default=cfg.curl_radii_m[0])[0]
    crl = curl(drg[-1:], np.array([radius]), cfg)[0]
    poses = np.concatenate([pen, drg[1:], crl[1:]])
    phases = np.concatenate([np.zeros(n_p), np.ones(n_d - 1), np.full(len(crl) - 1, 2)]).astype(np.int8)
    return poses, phases


def swept(poses: np.ndarray, surface: SurfaceProfile, width: float) -> np.ndarray:
    """Volume swept between consecutive samples of paths (..., S, 3) [m^3] (..., S-1): depth x travel x width."""
    xm = 0.5 * (poses[..., 1:, 0] + poses[..., :-1, 0])
    zm = 0.5 * (poses[..., 1:, 1] + poses[..., :-1, 1])
    dx = poses[..., :-1, 0] - poses[..., 1:, 0]
    return np.maximum(surface(xm) - zm, 0.0) * np.abs(dx) * width


def running_total(steps: np.ndarray) -> np.ndarray:
    """(..., S) prefix sums of per-step amounts (..., S-1) along the last axis, starting at 0."""
    return np.concatenate([np.zeros(steps.shape[:-1] + (1,)), np.cumsum(steps, axis=-1)], axis=-1)


def soil_depth(poses: np.ndarray, surface: SurfaceProfile) -> np.ndarray:
    """(...,) depth of each tip pose (..., 3) below the mapped surface [m], 0 above it."""
    return np.maximum(surface(poses[..., 0]) - poses[..., 1], 0.0)


def step_lengths(poses: np.ndarray) -> np.ndarray:
    """(..., S-1) lengths of the segments between consecutive samples of paths (..., S, 3) [m]."""
    return np.linalg.norm(np.diff(poses[..., :2], axis=-2), axis=-1)
