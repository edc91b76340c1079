"""The loading action and its constraints (Singh 1995 §3.5, §4.1-4.2, §7.2.1), for a 2-D pile.

**The action** (§3.5, Fig. 26): the bucket tip enters the pile's surface at horizontal distance ``k`` from
its near foot (``k < 0``, down to ``k_min``: on the bare ground in front of it, so that h = 0, the bucket set
on the ground and driven in, is among the entries; assumed), moves in a straight line for ``d1`` at the
approach angle ``alpha`` (below horizontal, positive down, as the trenching action's), then follows an arc
of radius ``r`` curving upwards, of length
``d2 = r (exit_heading + alpha)``, until it moves upwards at ``exit_heading`` (60 degrees from horizontal:
a bucket rolled back as far as a loader's goes; assumed, the thesis draws the arc without saying where it
ends); it then lifts out vertically through the surface.
The six variables (k, alpha, d1, d2, r, rho) of §3.5 reduce to:

* ``parameterization="k_alpha"``: independent (k, alpha); d1 maximized; r the smallest of ``radii`` whose
  end pose is reachable (§3.4.2.4, Fig. 23) and d2 from it: the bucket curls about the tightest radius
  after a long straight;
* ``parameterization="k_alpha_r"``: independent (k, alpha, r), d1 maximized: the curl varies (§3.5's
  alternative, a larger search).

§4.1 writes the same action as (alpha, h, d) (Fig. 27): ``h`` is the height at which the bucket enters
the pile, ``h = surface(foot + k)``, one-to-one with ``k`` on the pile's near face (up to its crest), and
``d`` is the dependent length, our maximized ``d1``. We search over k (it stays meaningful beyond the
crest, where h repeats) and report h beside it. ``rho``, the bucket's attitude, is not free (assumed):
the floor trails the tip as a chord of the path (:func:`floor_angle`), so the tip pose is fixed by the path.

**The constraints** (§4.1-4.2), each a function of the candidates, vectorized over all of them:

* shaping (§4.1.1): the path never below the ground (z >= -``tolerance``);
* volume (§4.1.2): the swept area, summed over the world's columns exactly as the world removes it, at
  most ``capacity``;
* reachability (§4.1.3, §4.2): every sample of the approach, the arc and the lift-out within the
  machine's joint limits by its inverse kinematics (:mod:`excavsim.robot.loaders`); for the loader, its
  wheels never pass the foot of the pile as it stands after the dig (Fig. 31 (b), and (c): a foot this
  dig removes lets the wheels on), the foot being where the soil is higher than ``wheel_clearance``
  (15 cm: what the wheels drive over; assumed);
* collision of the bucket with the terrain (Fig. 31 (a), Fig. 33 (a)): the floor, a chord of the convex
  path behind the tip, lies within what has been cut; so the bucket strikes terrain only behind its
  entry, along the approach line's backward extension of the floor's length: that must stay above the
  surface;
* force (§7.2.1, Fig. 110), when a limit is given: just before lift-out (at the arc's end) the bucket
  must lift the soil above its path and shear it from the pile along a vertical surface from the tip to
  the surface, of length L. Mohr-Coulomb strength ``c + K0 gamma z tan(phi)`` with the at-rest stress
  ``K0 = 1 - sin(phi)`` (Jaky) on that surface gives the resistive force per metre of width
  ``F = gamma A + c L + K0 gamma tan(phi) L^2 / 2`` [N/m], at most ``force_limit``. The thesis shows the
  shear surface only in its figure; its equation, the vertical surface and K0 are assumed.

The search (:func:`plan`) evaluates every candidate's constraints and, per (k, alpha) (and r), keeps
the longest feasible d1; the utility is the swept area (Fig. 35: "amount of soil excavated"), the
largest chosen, as the trenching objective ``volume`` does; a best dig under ``min_fraction`` of the
capacity is "no dig". The swept area is the planner's prediction of what the dig removes: in the 2-D
world of §7.2.1 it is exact. Numpy only.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from excavsim.errors import ConfigError
from excavsim.robot.loaders import FrontLoader, FrontShovel

LOADING_CONSTRAINTS = ("shaping", "volume", "reachability", "collision", "force")
PARAMETERIZATIONS = ("k_alpha", "k_alpha_r")


@dataclasses.dataclass(frozen=True)
class LoadingRules:
    """The loading action's grid and constraints (lengths [m], angles [rad], areas [m^2], forces [N/m])."""

    k_max: float = 4.0
    k_min: float = 0.0
    k_step: float = 0.1
    alpha_min: float = math.radians(-30.0)
    alpha_max: float = math.radians(40.0)
    alpha_step: float = math.radians(5.0)
    d1_max: float = 4.0
    d1_step: float = 0.1
    radii: tuple[float, ...] = (0.5, 0.75, 1.0, 1.5, 2.0)
    parameterization: str = "k_alpha"
    capacity: float = 0.48
    tolerance: float = 0.01
    sample_step: float = 0.25
    arc_samples: int = 7
    lift_clearance: float = 0.2
    min_fraction: float = 0.05
    ground: float = 0.05
    wheel_clearance: float = 0.15
    exit_heading: float = math.radians(60.0)
    base_backoffs: tuple[float, ...] = (0.0, 0.75, 1.5)
    force_limit: float | None = None
    unit_weight: float = 17_000.0
    friction_deg: float = 35.0
    cohesion: float = 0.0

    def __post_init__(self):
        pos = ("k_step", "alpha_step", "d1_max", "d1_step", "capacity", "sample_step", "unit_weight")
        for name in pos:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"loading rules: {name} must be a finite number > 0; given {v!r}")
        if not (self.k_max >= 0 and -10.0 <= self.k_min <= 0 and self.alpha_min <= self.alpha_max
                and -math.pi / 2 < self.alpha_min and self.alpha_max < math.pi / 2):
            raise ConfigError("loading rules: need k_max >= 0, -10 m <= k_min <= 0 and "
                              "-90 deg < alpha_min <= alpha_max < 90 deg")
        if not self.radii or any(not (math.isfinite(r) and r > 0) for r in self.radii):
            raise ConfigError(f"loading rules: radii must be a non-empty list of lengths > 0 m; given {self.radii!r}")
        if self.parameterization not in PARAMETERIZATIONS:
            raise ConfigError(f"loading rules: parameterization must be one of {PARAMETERIZATIONS}; "
                              f"given {self.parameterization!r}")
        if self.force_limit is not None and not (math.isfinite(self.force_limit) and self.force_limit > 0):
            raise ConfigError(f"loading rules: force_limit must be > 0 N/m or None; given {self.force_limit!r}")
        if not (0.0 < self.exit_heading <= math.pi / 2):
            raise ConfigError(f"loading rules: exit_heading must lie in (0, 90] degrees; given {self.exit_heading!r}")
        if not self.base_backoffs or any(not (math.isfinite(b) and b >= 0) for b in self.base_backoffs):
            raise ConfigError(f"loading rules: base_backoffs must be a non-empty list of lengths >= 0 m; "
                              f"given {self.base_backoffs!r}")
        if self.arc_samples < 2 or self.tolerance < 0 or self.cohesion < 0 or not (0 <= self.friction_deg < 90):
            raise ConfigError("loading rules: need arc_samples >= 2, tolerance >= 0, cohesion >= 0, "
                              "0 <= friction < 90 deg")

    def grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The k (from ``k_min``, ahead of the foot, to ``k_max``; 0 exactly on the grid), alpha, r (one NaN for
        ``k_alpha``: r is dependent) and d1 values of the grid."""
        n_ahead = int(math.floor(-self.k_min / self.k_step + 1e-9))
        k = np.concatenate([-self.k_step * np.arange(n_ahead, 0, -1), _steps(0.0, self.k_max, self.k_step)])
        a = _steps(self.alpha_min, self.alpha_max, self.alpha_step)
        r = np.array(self.radii, dtype=float) if self.parameterization == "k_alpha_r" else np.array([np.nan])
        d1 = _steps(self.d1_step, self.d1_max, self.d1_step)
        return k, a, r, d1


@dataclasses.dataclass(frozen=True)
class PileSection:
    """A vertical section of the pile as the planner sees it (in the 2-D world, exactly): column centres
    ``xs`` [m], heights [m], width ``dx`` [m]."""

    xs: np.ndarray
    heights: np.ndarray
    dx: float

    def __post_init__(self):
        xs, h = np.asarray(self.xs, float), np.asarray(self.heights, float)
        if xs.ndim != 1 or xs.shape != h.shape or xs.size < 2 or not (np.all(np.isfinite(xs))
                                                                     and np.all(np.isfinite(h))):
            raise ConfigError("terrain: xs and heights must be finite 1-D arrays of the same length (>= 2)")
        if np.any(np.diff(xs) <= 0) or not self.dx > 0:
            raise ConfigError("terrain: column centres must increase and dx be > 0")

    def surface(self, x) -> np.ndarray:
        """Heights at ``x`` (linear between column centres, the end columns' beyond)."""
        return np.interp(x, self.xs, self.heights)

    def foot(self, tol: float = 1e-3) -> float:
        """The near foot: the left edge of the first column above ``tol`` [m] (inf when the pile is gone).

        The planner uses ``LoadingRules.ground`` (5 cm: a layer thinner is ground to the wheels and tracks,
        and not "the pile"; assumed)."""
        idx = np.nonzero(self.heights > tol)[0]
        return math.inf if idx.size == 0 else float(self.xs[idx[0]] - 0.5 * self.dx)


@dataclasses.dataclass(frozen=True)
class LoadingAction:
    """One loading dig: entry ``k`` from the foot [m], ``alpha`` [rad], ``d1`` [m], arc radius ``r`` [m].

    ``foot`` [m] is where k is measured from (the pile's near foot when it was planned); ``d2`` [m] the
    arc's length, ``h`` the entry's height (§4.1's (alpha, h, d) with d = d1).
    """

    k: float
    alpha: float
    d1: float
    r: float
    foot: float
    h: float

    def d2(self, exit_heading: float) -> float:
        """The arc's length [m] when it turns up to ``exit_heading``."""
        return self.r * (exit_heading + self.alpha)

    @property
    def entry_x(self) -> float:
        return self.foot + self.k


@dataclasses.dataclass
class LoadingPlan:
    """The planner's answer and the action space it searched, for the loop and the figures.

    Per-cell arrays have the grid's shape (n_k, n_alpha, n_r): ``d1_max`` per constraint (the largest d1
    each constraint alone allows, NaN where none: the constraint surfaces of Figs. 28-33), the composite
    ``d1`` (all of them, Fig. 34), its ``volume`` (the utility, Fig. 35) [m^2], ``force`` [N/m] and ``r``.
    """

    action: LoadingAction | None
    reason: str
    volume: float
    force: float
    base_x: float
    grid_k: np.ndarray
    grid_alpha: np.ndarray
    grid_r: np.ndarray
    entry_h: np.ndarray
    d1_max: dict[str, np.ndarray]
    d1: np.ndarray
    cell_volume: np.ndarray
    cell_force: np.ndarray
    cell_r: np.ndarray
    seconds: float


# ---------------------------------------------------------------------------------------------- geometry
def floor_angle(alpha, turn, r, floor: float):
    """The floor's direction (from +x, counter-clockwise) with the tip ``turn`` [rad] into the arc.

    The floor is the chord of the path over the last ``floor`` metres behind the tip: on a circle its
    direction is the heading half a floor's length back, ``-alpha + max(turn - floor / (2 r), 0)``
    (on the straight, and while the floor still reaches back into it, the approach's ``-alpha``; assumed
    attitude, see the module docstring).
    """
    return -alpha + np.maximum(turn - floor / (2.0 * r), 0.0)


def arc_centre(xe, ze, alpha, d1, r):
    """The end of the straight (x1, z1) and the arc's centre (cx, cz) of actions (broadcast arrays)."""
    x1 = xe + d1 * np.cos(alpha)
    z1 = ze - d1 * np.sin(alpha)
    return x1, z1, x1 + r * np.sin(alpha), z1 + r * np.cos(alpha)


def arc_end(xe, ze, alpha, d1, r, exit_heading: float):
    """Where the arc ends and the lift-out starts (x, z): the heading has turned up to ``exit_heading``."""
    _, _, cx, cz = arc_centre(xe, ze, alpha, d1, r)
    return cx + r * math.sin(exit_heading), cz - r * math.cos(exit_heading)


def path_height(x, xe, ze, alpha, d1, r, exit_heading: float):
    """The path's height at ``x`` (broadcast): the straight over [xe, x1], the arc (its lower half) up to the
    lift-out; ``inf`` outside (nothing cut there)."""
    x1, z1, cx, cz = arc_centre(xe, ze, alpha, d1, r)
    line = ze - (x - xe) * np.tan(alpha)
    arc = cz - np.sqrt(np.maximum(r * r - (x - cx) ** 2, 0.0))
    xx = cx + r * math.sin(exit_heading)
    return np.where((x >= xe) & (x <= x1), line, np.where((x > x1) & (x <= xx), arc, np.inf))


def path_points(action: LoadingAction, exit_heading: float, xs: np.ndarray | None = None, *, arc_samples: int = 25,
                line_samples: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """The path of one action as a polyline (x increasing) from the entry to the lift-out.

    With ``xs`` (the world's column centres) the polyline has a point at every centre in its x range, at
    the path's exact height there, so that the world's carving removes exactly the swept area the
    planner computed; otherwise ``line_samples`` and ``arc_samples`` points.
    """
    a = action
    ze = a.h
    x1, z1, cx, cz = arc_centre(a.entry_x, ze, a.alpha, a.d1, a.r)
    if xs is None:
        t = np.linspace(0.0, 1.0, line_samples)
        lx, lz = a.entry_x + t * (x1 - a.entry_x), ze + t * (z1 - ze)
        psi = np.linspace(-a.alpha, exit_heading, arc_samples)[1:]
        return np.concatenate([lx, cx + a.r * np.sin(psi)]), np.concatenate([lz, cz - a.r * np.cos(psi)])
    xe, (xx, zz) = a.entry_x, arc_end(a.entry_x, ze, a.alpha, a.d1, a.r, exit_heading)
    inner = xs[(xs > xe) & (xs < xx)]
    px = np.concatenate([[xe], inner, [xx]])
    pz = path_height(px, xe, ze, a.alpha, a.d1, a.r, exit_heading)
    pz[-1] = zz
    return px, pz


def action_poses(action: LoadingAction, terrain: PileSection, rules: LoadingRules, floor: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Tip poses (S, 3) of one action and their phase (0 approach, 1 arc, 2 lift-out), as the search samples them."""
    poses, phase = _samples(np.array([action.entry_x]), np.array([action.h]), np.array([action.alpha]),
                            np.array([action.d1]), np.array([action.r]), terrain, rules, floor)
    return poses[0], phase


def _samples(xe, ze, alpha, d1, r, terrain: PileSection, rules: LoadingRules, floor: float):
    """(n, S, 3) sampled tip poses of n actions: the straight every ``sample_step`` (its end included), the
    arc at ``arc_samples`` turns, the lift-out at three heights up to ``lift_clearance`` above the surface."""
    n_line = int(math.ceil(rules.d1_max / rules.sample_step)) + 1
    s = np.minimum(np.arange(n_line)[None, :] * rules.sample_step, d1[:, None])
    lx = xe[:, None] + s * np.cos(alpha)[:, None]
    lz = ze[:, None] - s * np.sin(alpha)[:, None]
    lp = np.broadcast_to(-alpha[:, None], lx.shape)
    x1, z1, cx, cz = arc_centre(xe, ze, alpha, d1, r)
    frac = np.linspace(0.0, 1.0, rules.arc_samples)[None, :]
    turn = (rules.exit_heading + alpha)[:, None] * frac
    psi = -alpha[:, None] + turn
    ax = cx[:, None] + r[:, None] * np.sin(psi)
    az = cz[:, None] - r[:, None] * np.cos(psi)
    ap = floor_angle(alpha[:, None], turn, r[:, None], floor)
    ex, ez = arc_end(xe, ze, alpha, d1, r, rules.exit_heading)
    top = np.maximum(terrain.surface(ex) + rules.lift_clearance, ez)
    lift = np.linspace(0.0, 1.0, 4)[None, 1:]
    fx = np.broadcast_to(ex[:, None], (xe.size, 3))
    fz = ez[:, None] + lift * (top - ez)[:, None]
    fp = np.broadcast_to(ap[:, -1:], fx.shape)
    poses = np.stack([np.concatenate([lx, ax, fx], 1), np.concatenate([lz, az, fz], 1),
                      np.concatenate([lp, ap, fp], 1)], axis=-1)
    phase = np.concatenate([np.zeros(n_line), np.ones(rules.arc_samples), np.full(3, 2)]).astype(np.int8)
    return poses, phase


# ---------------------------------------------------------------------------------------------- constraints
def shaping(xe, ze, alpha, d1, r, tolerance: float) -> np.ndarray:
    """§4.1.1: the path's lowest point (the straight's end, or the arc's bottom when it turns through level)
    is not below the ground by more than ``tolerance``."""
    x1, z1, cx, cz = arc_centre(xe, ze, alpha, d1, r)
    lowest = np.where(alpha > 0, cz - r, z1)
    return np.minimum(lowest, ze) >= -tolerance


def swept_columns(terrain: PileSection, xe, ze, alpha, d1, r, exit_heading: float) -> tuple[np.ndarray, np.ndarray]:
    """Per action (n,) the swept area [m^2] and (n, m) the columns' heights after the dig.

    The world's rule (:meth:`excavsim.tasks.pile_loading.world.pile2d.Pile2D.carve`): a column whose centre lies in
    [entry, lift-out] drops to the path's height there (not below the ground) where the path is below it.
    """
    xs = terrain.xs[None, :]
    z = path_height(xs, xe[:, None], ze[:, None], alpha[:, None], d1[:, None], r[:, None], exit_heading)
    ex, _ = arc_end(xe, ze, alpha, d1, r, exit_heading)
    inside = (xs >= xe[:, None]) & (xs <= ex[:, None])
    after = np.where(inside, np.minimum(terrain.heights[None, :], np.maximum(z, 0.0)), terrain.heights[None, :])
    return ((terrain.heights[None, :] - after) * terrain.dx).sum(axis=1), after


def volume(area, capacity: float) -> np.ndarray:
    """§4.1.2: the swept area at most the bucket's capacity."""
    return area <= capacity


def collision(terrain: PileSection, xe, ze, alpha, floor: float, tolerance: float, n: int = 6) -> np.ndarray:
    """Fig. 31 (a) / 33 (a): the floor behind the entry, the approach's backward extension of ``floor`` metres
    (sampled at ``n`` points), stays above the surface (within ``tolerance``); see the module docstring."""
    t = np.linspace(1.0 / n, 1.0, n)[None, :] * floor
    hx = xe[:, None] - t * np.cos(alpha)[:, None]
    hz = ze[:, None] + t * np.sin(alpha)[:, None]
    return np.all(hz >= terrain.surface(hx) - tolerance, axis=1)


def reachable(machine: FrontLoader | FrontShovel, poses: np.ndarray, base_x: float,
              wheel_limit: np.ndarray | None = None) -> np.ndarray:
    """§4.1.3 / §4.2: whether every sampled pose (n, S, 3) is within the joint limits (the machine's IK) and,
    for the loader, its wheels' front at or behind ``wheel_limit`` (n,) [m] (Fig. 31 (b), (c))."""
    if machine.moves_base:
        q, ok = machine.inverse(poses)
        if wheel_limit is not None:
            ok &= np.nan_to_num(machine.wheels_x(q), nan=np.inf) <= wheel_limit[:, None] + 1e-9
    else:
        q, ok = machine.inverse(poses, base_x)
    return np.all(ok, axis=-1)


def shear_force(terrain: PileSection, area, x_out, z_out, rules: LoadingRules) -> np.ndarray:
    """Fig. 110: the resistive force per metre of width [N/m] just before lift-out at (x_out, z_out).

    See the module docstring: the soil above the path (``area`` [m^2]) and the vertical shear surface above the tip.
    """
    length = np.maximum(terrain.surface(x_out) - z_out, 0.0)
    phi = math.radians(rules.friction_deg)
    k0 = 1.0 - math.sin(phi)
    return (rules.unit_weight * area + rules.cohesion * length
            + 0.5 * k0 * rules.unit_weight * math.tan(phi) * length ** 2)


def force(f, limit: float | None) -> np.ndarray:
    """The force constraint: the resistive force within ``limit`` (all pass without one)."""
    return np.ones(np.shape(f), bool) if limit is None else f <= limit


def base_position(machine: FrontLoader | FrontShovel, terrain: PileSection, ground: float = 1e-3) -> float:
    """The shovel's nearest base (the first of :func:`base_candidates` with no back-off); NaN for the loader."""
    c = base_candidates(machine, terrain, LoadingRules(ground=ground, base_backoffs=(0.0,)))
    return c[0][0] if c else math.nan


def base_candidates(machine: FrontLoader | FrontShovel, terrain: PileSection, rules: LoadingRules
                    ) -> list[tuple[float, float]]:
    """Where a shovel's pivot may stand for the next dig (§4.2: the base is placed between digs), with the foot
    its entries k are measured from: ``[(base_x, foot), ...]`` (the loader: ``[(NaN, the pile's foot)]``).

    The tracks drive over soil no higher than ``wheel_clearance`` (as the loader's wheels), from the open
    ground on the near side: their front goes at most to the first column higher than that (the
    *drive limit*; the pile's foot when no column is), and stands there or ``base_backoffs`` [m] behind it
    (a shovel digs poorly right at its tracks). Each candidate's entries start at the first column above
    ``ground`` ahead of its tracks' front. Assumed: the thesis says only that the base is positioned between
    digs; the planner takes the candidate with the largest dig (the nearest on ties).
    """
    foot = terrain.foot(rules.ground)
    if not machine.moves_base and math.isfinite(foot):
        high = np.nonzero(terrain.heights > rules.wheel_clearance)[0]
        limit = float(terrain.xs[high[0]] - 0.5 * terrain.dx) if high.size else foot
        soil = terrain.heights > rules.ground
        out = []
        for back in rules.base_backoffs:
            front = limit - back
            ahead = np.nonzero(soil & (terrain.xs + 0.5 * terrain.dx > front + 1e-9))[0]
            if ahead.size:
                ref = max(float(terrain.xs[ahead[0]] - 0.5 * terrain.dx), front)
                out.append((front - machine.track_front, ref))
        return out
    if machine.moves_base:
        return [(math.nan, foot)]
    return []


# ---------------------------------------------------------------------------------------------- the search
def _smallest_radius(machine, terrain, rules, xe, ze, alpha, d1, base_x, floor) -> np.ndarray:
    """§3.4.2.4 / Fig. 23 for ``k_alpha``: the smallest radius whose arc's end pose is reachable (NaN if none)."""
    r_out = np.full(xe.size, np.nan)
    for r in rules.radii:
        todo = np.isnan(r_out)
        if not todo.any():
            break
        idx = np.nonzero(todo)[0]
        rr = np.full(idx.size, r)
        ex, ez = arc_end(xe[idx], ze[idx], alpha[idx], d1[idx], rr, rules.exit_heading)
        end = np.stack([ex, ez, floor_angle(alpha[idx], rules.exit_heading + alpha[idx], rr, floor)], axis=-1)
        if machine.moves_base:
            ok = machine.inverse(end)[1]
        else:
            ok = machine.inverse(end, base_x)[1]
        r_out[idx[ok]] = r
    return r_out


def evaluate(machine: FrontLoader | FrontShovel, terrain: PileSection, rules: LoadingRules, xe, ze, alpha, d1, r,
             base_x: float) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Every constraint on n candidate actions (flat arrays; ``r`` NaN: no reachable radius).

    Returns:
        Per constraint (n,) bool, the swept areas (n,) [m^2] and the resistive forces (n,) [N/m].
    """
    floor = machine.floor
    ok_r = np.isfinite(r)
    rr = np.where(ok_r, r, rules.radii[0])
    area, after = swept_columns(terrain, xe, ze, alpha, d1, rr, rules.exit_heading)
    out = {"shaping": shaping(xe, ze, alpha, d1, rr, rules.tolerance), "volume": volume(area, rules.capacity),
           "collision": collision(terrain, xe, ze, alpha, floor, rules.tolerance)}
    wheel_limit = None
    if machine.moves_base:
        high = after > rules.wheel_clearance
        first = np.where(high.any(axis=1), np.argmax(high, axis=1), terrain.xs.size - 1)
        wheel_limit = terrain.xs[first] - 0.5 * terrain.dx
    poses, _ = _samples(xe, ze, alpha, d1, rr, terrain, rules, floor)
    out["reachability"] = ok_r & reachable(machine, poses, base_x, wheel_limit)
    ex, ez = arc_end(xe, ze, alpha, d1, rr, rules.exit_heading)
    f = shear_force(terrain, area, ex, ez, rules)
    out["force"] = force(f, rules.force_limit)
    return out, area, f


def plan(machine: FrontLoader | FrontShovel, terrain: PileSection, rules: LoadingRules) -> LoadingPlan:
    """Choose one loading dig on ``terrain`` (see the module docstring); for the shovel also where its base
    stands (:func:`base_candidates`): the candidate whose best dig is the largest."""
    t0 = time.perf_counter()
    best = None
    for base_x, foot in base_candidates(machine, terrain, rules) or [(math.nan, math.inf)]:
        p = _plan_at(machine, terrain, rules, foot, base_x)
        if best is None or (p.action is not None and (best.action is None or p.volume > best.volume + 1e-12)):
            best = p
    best.seconds = time.perf_counter() - t0
    return best


def _plan_at(machine: FrontLoader | FrontShovel, terrain: PileSection, rules: LoadingRules, foot: float,
             base_x: float) -> LoadingPlan:
    """The best dig with entries measured from ``foot`` and (the shovel) the pivot at ``base_x``."""
    t0 = time.perf_counter()
    gk, ga, gr, gd = rules.grid()
    shape = (gk.size, ga.size, gr.size)
    nan_cells = np.full(shape, np.nan)
    if not math.isfinite(foot):
        return LoadingPlan(None, "no pile left", 0.0, 0.0, base_x, gk, ga, gr, np.full(gk.size, np.nan),
                           {c: nan_cells.copy() for c in LOADING_CONSTRAINTS}, nan_cells.copy(), nan_cells.copy(),
                           nan_cells.copy(), nan_cells.copy(), time.perf_counter() - t0)
    kk, aa, rr, dd = np.meshgrid(gk, ga, gr, gd, indexing="ij")
    kk, aa, rr, dd = kk.ravel(), aa.ravel(), rr.ravel(), dd.ravel()
    xe = foot + kk
    ze = terrain.surface(xe)
    if rules.parameterization == "k_alpha":
        rr = _smallest_radius(machine, terrain, rules, xe, ze, aa, dd, base_x, machine.floor)
    verdicts, area, f = evaluate(machine, terrain, rules, xe, ze, aa, dd, rr, base_x)
    full = shape + (gd.size,)
    d1_max = {c: _longest(verdicts[c].reshape(full), gd) for c in LOADING_CONSTRAINTS}
    every = np.logical_and.reduce([verdicts[c] for c in LOADING_CONSTRAINTS]).reshape(full)
    any_ok = every.any(axis=-1)
    j = np.where(any_ok, gd.size - 1 - np.argmax(every[..., ::-1], axis=-1), 0)
    pick = lambda a: np.where(any_ok, np.take_along_axis(a.reshape(full), j[..., None], -1)[..., 0], np.nan)  # noqa: E731
    cell_d1 = np.where(any_ok, gd[j], np.nan)
    cell_v, cell_f, cell_r = pick(area), pick(f), pick(rr)
    entry_h = terrain.surface(foot + gk)
    action, reason, vol, frc = None, "no feasible dig", 0.0, 0.0
    if any_ok.any():
        c = int(np.nanargmax(np.where(any_ok, cell_v, -np.inf)))
        ik, ia, ir = np.unravel_index(c, shape)
        vol = float(cell_v[ik, ia, ir])
        if vol < rules.min_fraction * rules.capacity:
            reason = (f"best dig sweeps {vol:.3f} m^2, below the minimum "
                      f"{100 * rules.min_fraction:.0f} % of capacity")
        else:
            action = LoadingAction(float(gk[ik]), float(ga[ia]), float(cell_d1[ik, ia, ir]), float(cell_r[ik, ia, ir]),
                                 foot, float(entry_h[ik]))
            frc = float(cell_f[ik, ia, ir])
            reason = "max volume"
    return LoadingPlan(action, reason, vol if action else 0.0, frc, base_x, gk, ga, gr, entry_h, d1_max, cell_d1,
                       cell_v, cell_f, cell_r, time.perf_counter() - t0)


def _longest(ok: np.ndarray, d1: np.ndarray) -> np.ndarray:
    """The largest d1 (last axis) where ``ok`` holds, NaN where it never does."""
    any_ok = ok.any(axis=-1)
    j = d1.size - 1 - np.argmax(ok[..., ::-1], axis=-1)
    return np.where(any_ok, d1[j], np.nan)


def _steps(lo: float, hi: float, step: float) -> np.ndarray:
    n = int(math.floor((hi - lo) / step + 1e-9)) + 1
    return lo + step * np.arange(max(n, 1))
