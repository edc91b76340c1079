"""Benchmarks: numbers and ratios measured side by side in one run (never asserted in tests).

``excavsim bench`` runs them all and prints one table. Each benchmark returns rows of
(name, value, unit, note) and is listed in :data:`BENCHMARKS`. Nothing in the package imports this
module: only the CLI does.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from excavsim import constants, processes


class Row(NamedTuple):
    """One line of the bench table: a figure, its unit, a note, and its target where it has one.

    ``target`` is the bound the figure should meet, ``sense`` says how (``"<="`` or ``">="``);
    :attr:`met` is None for figures without a target.
    """

    name: str
    value: float
    unit: str
    note: str
    target: float | None = None
    sense: str = "<="

    @property
    def met(self) -> bool | None:
        if self.target is None:
            return None
        return bool(self.value <= self.target) if self.sense == "<=" else bool(self.value >= self.target)


@dataclasses.dataclass(frozen=True)
class Timing:
    """CPU and wall time of repeated runs of one piece of work [s] (CPU: this process, all threads).

    The machines are shared and noisy: CPU time is the figure to compare, wall time is printed
    beside it; both as median and range.
    """

    cpu: np.ndarray
    wall: np.ndarray

    @property
    def cpu_median(self) -> float:
        return float(np.median(self.cpu))

    @property
    def wall_median(self) -> float:
        return float(np.median(self.wall))

    def describe(self, scale: float = 1.0, unit: str = "s") -> str:
        """``CPU median [min-max], wall median [min-max] over N runs`` in ``unit`` (values times ``scale``)."""
        def span(a: np.ndarray) -> str:
            return f"{np.median(a) * scale:.3g} [{a.min() * scale:.3g}-{a.max() * scale:.3g}]"
        return f"CPU {span(self.cpu)} {unit}, wall {span(self.wall)} {unit}, {len(self.cpu)} runs"


def _timed(fn: Callable[[], object], repeats: int) -> Timing:
    """CPU and wall time of ``repeats`` runs of ``fn`` (warm: compile first, outside the timing)."""
    cpu, wall = [], []
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return Timing(np.asarray(cpu), np.asarray(wall))


def _best_of(fn: Callable[[], object], repeats: int) -> float:
    """Median CPU time of ``repeats`` runs of ``fn`` [s] (the throughput figures' basis)."""
    return _timed(fn, repeats).cpu_median


def bench_step_rate(*, seconds: float = 5.0) -> list[Row]:
    """MuJoCo step rate of the full scene with the servos tracking a sinusoidal target."""
    from excavsim.config import load_robot_config
    from excavsim.robot.servo import setpoint_rates
    from excavsim.world.scene import build_physics

    robot = load_robot_config()
    physics = build_physics(robot)
    dt = physics.model.opt.timestep
    substeps = max(1, int(round(1.0 / robot.control_rate_hz / dt)))
    q0 = physics.data.qpos.copy()
    rate_limit = physics.model.actuator_ctrlrange[:, 1]
    n_ctrl = int(seconds / (substeps * dt))
    raw = _best_of(lambda: physics.step(n_ctrl * substeps), 1)  # holding still, no Python per step
    physics.reset(keyframe_id=constants.KEYFRAMES.index("home"))
    t0 = time.perf_counter()
    for k in range(n_ctrl):
        t = k * substeps * dt
        target = q0 + 0.2 * np.sin(0.5 * t) * np.array([1, 1, 0.5, 1, 0.5, 0.5])
        physics.data.ctrl[:] = setpoint_rates(target, physics.data.qpos, gain_per_s=robot.setpoint_gain_per_s,
                                              rate_limit=rate_limit)
        physics.step(substeps)
    moving = time.perf_counter() - t0
    n = n_ctrl * substeps
    return [
        ("scene step rate, holding (bulk physics.step)", n / raw, "steps/s", f"dt {dt * 1e3:.1f} ms"),
        ("scene step rate, tracking at control rate", n / moving, "steps/s",
         f"{robot.control_rate_hz:.0f} Hz control, {substeps} steps each"),
        ("scene real-time factor, tracking", n * dt / moving, "x", "simulated s per wall s"),
    ]


def bench_kinematics(*, n: int = 100_000) -> list[Row]:
    """Vectorized FK, IK and Jacobian throughput, and the ratio to a per-pose Python loop."""
    import mujoco

    from excavsim.robot.extract import arm_from_model

    arm = arm_from_model(mujoco.MjModel.from_xml_path(str(constants.SCENE_XML)))
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower, arm.upper, (n, 3))
    poses = arm.forward(q)
    t_fk = _best_of(lambda: arm.forward(q), 3)
    t_ik = _best_of(lambda: arm.inverse(poses), 3)
    t_jac = _best_of(lambda: arm.jacobian(q), 3)
    m = 2000
    t_ik_loop = _best_of(lambda: [arm.inverse(p) for p in poses[:m]], 1) * n / m
    return [
        ("FK, vectorized", n / t_fk, "poses/s", f"batch of {n}"),
        ("IK, vectorized", n / t_ik, "poses/s", f"batch of {n}"),
        ("Jacobian, vectorized", n / t_jac, "poses/s", f"batch of {n}"),
        ("IK vectorized / per-pose loop", t_ik_loop / t_ik, "x speed-up", f"loop timed on {m} poses"),
    ]


def bench_reachability(*, n: int = 1_000_000) -> list[Row]:
    """Reachability table: build time, lookups per second, and the speed-up over exact IK."""
    import mujoco

    from excavsim.robot.extract import arm_from_model
    from excavsim.robot.reachability import ReachabilityTable

    arm = arm_from_model(mujoco.MjModel.from_xml_path(str(constants.SCENE_XML)))
    t0 = time.perf_counter()
    table = ReachabilityTable.build(arm)
    t_build = time.perf_counter() - t0
    rng = np.random.default_rng(1)
    poses = np.stack([rng.uniform(0.5, 3.0, n), rng.uniform(0.0, 1.5, n),
                      np.radians(rng.uniform(-90, 90, n))], axis=-1)
    t_lookup = _best_of(lambda: table.contains(poses), 3)
    t_exact = _best_of(lambda: arm.reachable(poses), 3)
    cells = table.x_lo.shape[0] * table.x_lo.shape[1]
    return [
        ("reachability table build", t_build, "s", f"{cells} cells (1 cm x 1 deg), {table.n_gapped} split"),
        ("reachability lookup", n / t_lookup, "poses/s", f"batch of {n}"),
        ("lookup / exact IK", t_exact / t_lookup, "x speed-up", "same poses"),
    ]


def bench_soil_coupling() -> list[Row]:
    """Real-time factor of the demo dig with the soil coupled, and the cost ratio to the bare arm.

    The demo (``excavsim demo``: park, scan, one hand-picked dig, dump, settle, scan) runs once with
    the soil; its servo commands are recorded and replayed on a fresh simulation with the soil
    switched off, so both runs step MuJoCo through the same control sequence. Only
    ``Simulation.step`` is timed; the first run also compiles the numba kernels, so a warm-up demo
    runs first.
    """
    from excavsim.handoff.dig import DEMO_ACTION
    from excavsim.loop.scenario import EpisodeSpec, resolve
    from excavsim.world.simulation import Simulation

    spec = EpisodeSpec(name="demo", goal="sand", dig_budget=1, done_fraction=None)  # the default task's demo dig
    resolved = resolve(spec)

    def run_demo(sim: Simulation):
        episode = spec.plugin.episode(spec, resolved)
        episode.reset(0, sim=sim, digs=spec.plugin.dig_source("scripted", [DEMO_ACTION]))
        return episode.run()

    class Recorder(Simulation):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.ctrls: list[np.ndarray] = []
            self.step_time = 0.0

        def step(self, ctrl=None):
            self.ctrls.append(np.array(ctrl))
            t0 = time.perf_counter()
            obs = super().step(ctrl)
            self.step_time += time.perf_counter() - t0
            return obs

    run_demo(Simulation(seed=0))  # warm-up: numba compilation and caches
    sim = Recorder(seed=0)
    t0 = time.perf_counter()
    result = run_demo(sim)
    wall = time.perf_counter() - t0
    bare = Simulation(seed=0)
    bare.soil_enabled = False
    t0 = time.perf_counter()
    for ctrl in sim.ctrls:
        bare.step(ctrl)
    t_bare = time.perf_counter() - t0
    sim_time = len(sim.ctrls) * sim.control_dt
    dug = sum(d.bucket_m3 for d in result.digs)
    return [
        ("dig with soil: real-time factor (Simulation.step)", sim_time / sim.step_time, "x",
         f"{sim_time:.1f} s simulated, {len(sim.ctrls)} control steps"),
        ("dig without soil: real-time factor", sim_time / t_bare, "x", "same control sequence replayed"),
        ("soil coupling cost ratio", sim.step_time / t_bare, "x", "with soil / without; target <= 2"),
        ("soil step cost", (sim.step_time - t_bare) / len(sim.ctrls) * 1e6, "us/step",
         f"extra per control step (soil kernel, settlement, applied wrench); dug {1000 * dug:.1f} l"),
        ("demo end to end (scan, IK, servo, soil)", result.sim_time_s / wall, "x", "real-time factor"),
    ]


def _trench_field(cell_size_m: float = 0.025) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The benchmark field: 121 x 121 cells flat at 0.5 m with a 1.2 x 0.3 x 0.4 m trench, and its cells."""
    heights = np.full((121, 121), 0.5)
    rows, cols = (30, 30 + round(1.2 / cell_size_m)), (54, 54 + round(0.3 / cell_size_m))
    heights[rows[0]:rows[1], cols[0]:cols[1]] -= 0.4
    return heights, (*rows, *cols)


def bench_settle(*, repeats: int = 7) -> list[Row]:
    """Settlement speed on the trench of Fig. 6 and the speed-up of a region settle after a small dig.

    Times are the best of ``repeats`` runs on fresh copies, with numba compilation done beforehand.
    """
    from excavsim.world.settle import SettleResult, settle

    cell, repose, tol = 0.025, math.radians(30.0), 1e-3
    w = settle.__kwdefaults__["over_relaxation"]
    settle(_trench_field(cell)[0], cell, repose)  # compile (or load the cache) outside the timing

    def timed(field: np.ndarray, **kwargs) -> tuple[float, SettleResult, np.ndarray]:
        copies = [field.copy() for _ in range(repeats)]
        results = []
        seconds = _best_of(lambda: results.append(settle(copies[len(results)], cell, repose, **kwargs)), repeats)
        return seconds, results[-1], copies[-1]

    trench, (r0, r1, c0, c1) = _trench_field(cell)
    t_trench, res, settled = timed(trench)
    volume_error = float(abs(settled.sum() - trench.sum()) / trench.sum())
    # Mirror asymmetry about the trench centre lines (the window symmetric about them).
    sym = settled[:r0 + r1, :c0 + c1]
    asymmetry = float(max(np.abs(sym - sym[::-1]).max(), np.abs(sym - sym[:, ::-1]).max()))

    # A 0.3 x 0.3 x 0.1 m hole dug into the settled field, on flat ground beside the trench.
    hole = settled.copy()
    n = round(0.3 / cell)
    region = (90, 90 + n, 20, 20 + n)
    hole[region[0]:region[1], region[2]:region[3]] -= 0.1
    t_region, res_region, after_region = timed(hole, region=region)
    t_whole, res_whole, after_whole = timed(hole)
    same = "identical result" if np.array_equal(after_region, after_whole) else "results differ"
    return [
        ("settle trench 121x121 (2.5 cm, 30 deg)", t_trench * 1e3, "ms", f"w {w}, tolerance {tol * 1e3:g} mm"),
        ("settle trench sweeps", res.iterations, "sweeps", f"moved {res.moved_volume_m3 * 1e3:.0f} L"),
        ("settle trench residual excess", res.residual_excess_m * 1e3, "mm", f"converged {res.converged}"),
        ("settle trench volume error", volume_error, "relative", "walls at the border"),
        ("settle trench mirror asymmetry", asymmetry * 1e3, "mm", "sweep order breaks symmetry"),
        ("settle 0.3 m hole, region", t_region * 1e3, "ms", f"{res_region.iterations} sweeps, {same}"),
        ("settle 0.3 m hole, whole grid", t_whole * 1e3, "ms", f"{res_whole.iterations} sweeps"),
        ("settle region / whole grid", t_whole / t_region, "x speed-up", "same hole in a settled field"),
    ]


def bench_wedge(*, n: int = 1_000_000, soil_name: str = "testbed_sand") -> list[Row]:
    """Wedge-force throughput with the table and with the exact beta*, and the table build time."""
    from excavsim.config import get_soil
    from excavsim.mechanics.wedge import WedgeTable, wedge_force

    soil = get_soil(soil_name)
    t0 = time.perf_counter()
    table = WedgeTable.for_soil(soil)
    t_build = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.0, 0.3, n)
    rake = rng.uniform(math.radians(10.0), math.radians(90.0), n)

    def best_of(fn) -> float:
        return _best_of(fn, 3)

    t_table = best_of(lambda: wedge_force(depth, rake, soil, 0.3, table=table))
    t_exact = best_of(lambda: wedge_force(depth, rake, soil, 0.3))
    note = f"batch of {n}, {soil_name}, rake 10-90 deg, depth 0-0.3 m"
    return [
        ("wedge table build", t_build, "s", f"{table.rake.size} rakes, {math.degrees(table.rake_step):.2g} deg step"),
        ("wedge force, table lookup", n / t_table, "evals/s", note),
        ("wedge force, exact beta*", n / t_exact, "evals/s", note),
        ("wedge table / exact", t_exact / t_table, "x speed-up", "same inputs"),
    ]


def bench_sensing(*, repeats: int = 5) -> list[Row]:
    """One scan, 10-scan elevation maps of the whole box, and the analytic caster against mj_ray.

    Maps as the loop takes them: the first on a fresh terrain (every ray cast once, then reused by
    the other nine scans), and maps after a dig (a 0.3 x 0.3 m hole 5 cm deep and its spoil dropped
    nearby), when only the rays that can see the change are recast. Each map is timed against the
    same map with every ray of every scan cast afresh (the scanner before it kept its ranges).
    Target: a map after the first <= 60 ms CPU.
    """
    import mujoco

    from excavsim.config import load_sensing_config
    from excavsim.sensing.elevation import build_map, map_accuracy
    from excavsim.world.scanner import LaserScanner
    from excavsim.world.simulation import Simulation

    cfg = load_sensing_config()
    sim = Simulation(seed=0)
    grid = sim.soil.grid
    scanner = LaserScanner(sim.model, grid, cfg.scanner, np.random.default_rng(0))
    n_rays = scanner.geometry.directions.shape[0] * scanner.geometry.directions.shape[1]
    result = {}

    def make_map(fresh: bool = False):
        images = []
        for _ in range(cfg.map.n_scans):
            if fresh:
                scanner._cache.clear()  # the scanner before it: every scan cast every ray
            images.append(scanner.scan(0.0))
        result["map"] = build_map(images, scanner.geometry, cfg.map)

    make_map()  # compile (or load the numba cache) outside the timing
    rng = np.random.default_rng(0)
    nr, nc = grid.shape
    holes = iter(range(10_000))

    def dig():  # a 0.3 m hole 5 cm deep, its soil dropped as a heap beside it
        i = next(holes)
        r0, c0 = 20 + (7 * i) % (nr - 60), 20 + (11 * i) % (nc - 60)
        n = round(0.3 / grid.cell)
        grid.heights[r0:r0 + n, c0:c0 + n] -= 0.05
        grid.heights[r0:r0 + n, c0 + n + 2:c0 + 2 * n + 2] += 0.05 * (1 + 0.1 * rng.random((n, n)))

    def first_map():
        scanner._cache.clear()
        make_map()

    def map_after_dig():
        dig()
        make_map()

    def map_after_dig_fresh():
        dig()
        make_map(fresh=True)

    saved = grid.heights.copy()
    t_scan = _timed(lambda: (scanner._cache.clear(), scanner.scan()), repeats)
    t_first = _timed(first_map, repeats)
    rays0 = scanner.cast_stats["rays"]
    t_after = _timed(map_after_dig, repeats)
    recast = (scanner.cast_stats["rays"] - rays0) / repeats / (n_rays + scanner.geometry.target_ranges.size)
    t_after_fresh = _timed(map_after_dig_fresh, repeats)
    grid.heights[...] = saved
    scanner._cache.clear()
    make_map()
    emap, cals = result["map"]
    acc = map_accuracy(emap, grid.surface_z, cals)
    # mj_ray on the same rays (from just outside the scanner housing), soil and box groups only
    dirs = scanner.geometry.directions.reshape(-1, 3)[:: max(1, n_rays // 2000)]
    start = scanner.geometry.origin + 0.25 * dirs
    group = np.array([1, 1, 0, 0, 0, 0], np.uint8)
    gid = np.zeros(1, np.int32)

    def mj_rays():
        for p, d in zip(start, dirs):
            mujoco.mj_ray(sim.model, sim.data, p, d, group, 1, -1, gid)

    t_mj = _timed(mj_rays, 1).cpu_median / len(dirs)
    t_ours = _best_of(lambda: scanner.true_ranges(np.ascontiguousarray(dirs)), repeats) / len(dirs)
    ms = lambda t: t.cpu_median * 1e3  # noqa: E731
    return [
        Row("scan, every ray cast (analytic rays, errors)", ms(t_scan), "ms CPU",
            f"{n_rays} image rays + {scanner.geometry.target_ranges.size} target rays; {t_scan.describe(1e3, 'ms')}"),
        Row("map of 10 scans, first on a terrain", ms(t_first), "ms CPU",
            f"rays cast once, reused by 9 scans; {t_first.describe(1e3, 'ms')}"),
        Row("map of 10 scans after a dig", ms(t_after), "ms CPU",
            f"{100 * recast:.1f} % of the rays recast; {t_after.describe(1e3, 'ms')}", 60.0, "<="),
        Row("map of 10 scans after a dig, every ray cast", ms(t_after_fresh), "ms CPU",
            f"the scanner before: 10 full casts; {t_after_fresh.describe(1e3, 'ms')}"),
        Row("map after a dig: every ray / recast", t_after_fresh.cpu_median / t_after.cpu_median, "x speed-up",
            "same digs, same scans"),
        Row("ray cost, analytic", t_ours * 1e6, "us/ray CPU", "numba, parallel over rays (CPU of all threads)"),
        Row("ray cost, mj_ray", t_mj * 1e6, "us/ray CPU", "same rays, soil + walls + targets"),
        Row("mj_ray / analytic", t_mj / t_ours, "x speed-up", ""),
        Row("map error RMS (defaults, flat sand)", 100 * acc.rms_m, "cm",
            f"max {100 * acc.max_m:.2f} cm, {100 * acc.observed_fraction:.0f} % observed"),
        Row("target residual RMS after calibration", 100 * acc.target_rms_m, "cm", "thesis: about 2 cm (§7.1.2)"),
    ]


def bench_planner(*, n_loop: int = 150, repeats: int = 5) -> list[Row]:
    """The exhaustive trenching planner over its ~10^4-cell grid: the compiled kernel against the
    vectorized reference it replaces for the nominal wedge model, and against a per-action loop.

    All five constraints, the force constraint (nominal wedge predictor) included, on the flat
    0.5 m fill and the goal of ``configs/trenches/straight.yaml``, in CPU time. The loop runs the
    reference evaluation one candidate at a time on ``n_loop`` cells spread over the grid; its time
    is scaled to the grid. Target: <= 50 ms per 10^4 candidates on one core.
    """
    import mujoco

    from excavsim.config import get_soil, load_planner_config, load_robot_config, load_trench_goal
    from excavsim.handoff.goal import SurfaceProfile
    from excavsim.handoff.maps import ElevationMap
    from excavsim.planning.predictor import WedgePredictor
    from excavsim.planning.search import TrenchPlanner
    from excavsim.robot.extract import arm_from_model
    from excavsim.robot.reachability import load_or_build

    model = mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))
    arm = arm_from_model(model)
    table = load_or_build(arm)
    robot = load_robot_config()
    limits = np.array([robot.joints.shoulder.torque_limit_nm, robot.joints.elbow.torque_limit_nm,
                       robot.joints.wrist_pitch.torque_limit_nm])
    soil = get_soil("testbed_sand")
    width = float(model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    goal = load_trench_goal(constants.TRENCHES_DIR / "straight.yaml")
    planner = TrenchPlanner(arm, table, limits, width, capacity, goal,
                            load_planner_config(), WedgePredictor(soil, width), soil.density_kg_m3)
    emap = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)
    result = {}
    c0 = time.process_time()
    result["r"] = planner.plan(emap)  # compile (or load the numba cache)
    t_first = time.process_time() - c0
    planner.plan(emap, kernel=False)
    t_plan = _timed(lambda: result.setdefault("r", planner.plan(emap)), repeats)
    t_ref = _timed(lambda: planner.plan(emap, kernel=False), repeats)
    t_full = _timed(lambda: planner.plan(emap, prune=False), 1)
    res = result["r"]
    ref = planner.plan(emap, kernel=False)
    same = bool(np.array_equal(res.feasible, ref.feasible) and res.action == ref.action)
    n = res.feasible.size
    surface = SurfaceProfile.from_map(emap, arm, 0.0, width)
    kk, aa, dd = np.meshgrid(planner.grid_k, planner.grid_alpha, planner.grid_d1, indexing="ij")
    cells = np.linspace(0, n - 1, n_loop).astype(int)

    def loop():
        for c in cells:
            k, a, d = kk.ravel()[c:c + 1], aa.ravel()[c:c + 1], dd.ravel()[c:c + 1]
            pen = planner.penetrate(k, a, d, surface)
            planner.evaluate_cells(pen, planner.drag(pen[:, -1]), surface, capacity)

    t_loop = _timed(loop, 1).cpu_median * n / n_loop
    per = 1e7 / n  # seconds per plan -> ms per 10^4 cells
    return [
        Row("planner: exhaustive search, compiled kernel", t_plan.cpu_median * per, "ms/1e4 CPU",
            f"{n} cells, {res.counts['evaluated']} evaluated, one core; {t_plan.describe(per, 'ms/1e4')}", 50.0, "<="),
        Row("planner: the same, vectorized reference", t_ref.cpu_median * per, "ms/1e4 CPU",
            f"numpy over the cells (learned predictors use it); {t_ref.describe(per, 'ms/1e4')}"),
        Row("planner: reference / kernel", t_ref.cpu_median / t_plan.cpu_median, "x speed-up",
            "same feasible set and dig" if same else "RESULTS DIFFER"),
        Row("planner: first plan in this process", t_first, "s CPU", "numba cache load (compile if cold)"),
        Row("planner: no pruning (reference)", t_full.cpu_median * 1e3, "ms CPU", "every constraint on every cell"),
        Row("planner: per-action loop (reference)", t_loop * 1e3, "ms CPU", f"timed on {n_loop} cells, scaled"),
        Row("planner: vectorized reference / loop", t_loop / t_ref.cpu_median, "x speed-up", ""),
    ]


def bench_episode(*, dig_budget: int = 20, seed: int = 0) -> list[Row]:
    """The default trenching episode (the sand trench, testbed sand, 20 digs at most) end to end, in CPU time.

    The simulated-to-CPU ratio of the whole loop (parking, scanning, mapping, planning, digging,
    settling), against **bare MuJoCo**: ``mj_step`` of the same scene for the same number of
    physics steps in one call, with no Python per step (the servo commands of the episode held in
    blocks; soil off). Also the same commands replayed per control step through
    ``Simulation.step`` with the soil off (the per-step Python without the loop). Where the CPU
    goes: stepping (MuJoCo with the soil, in ``Simulation.step``), scanning and mapping, planning,
    and the rest (the executor's script engine, IK and F/T per control step; settlement).
    Targets: >= 100x real time in CPU time, <= 3x bare MuJoCo.
    """
    import mujoco

    from excavsim.handoff.episode import EpisodeObserver
    from excavsim.loop.scenario import EpisodeSpec, resolve, run_spec, spec_digs, spec_episode
    from excavsim.world.simulation import Simulation

    class Timed(Simulation):
        """Times Simulation.step (MuJoCo + soil) and keeps the servo commands for the bare replay."""

        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.step_s = 0.0
            self.ctrls: list[np.ndarray] = []

        def step(self, ctrl=None):
            t0 = time.process_time()
            obs = super().step(ctrl)
            self.step_s += time.process_time() - t0
            self.ctrls.append(self.data.ctrl.copy())
            return obs

    class Phases(EpisodeObserver):
        """CPU time from the end of each dig (or the start) to its scan, less the stepping of the
        parking move in it: scanning and mapping."""

        def __init__(self, sim):
            self.sim = sim
            self.scan_s = 0.0
            self._mark = (time.process_time(), 0.0)

        def scanned(self, index, emap, accuracy):
            self.scan_s += time.process_time() - self._mark[0] - (self.sim.step_s - self._mark[1])

        def dug(self, index, record, metrics):
            self._mark = (time.process_time(), self.sim.step_s)

    run_spec(EpisodeSpec(goal="small", dig_budget=1, seed=seed))  # warm-up: numba caches, reachability table
    spec = EpisodeSpec(goal="sand", dig_budget=dig_budget, seed=seed)
    r = resolve(spec)
    sim = Timed(r.robot, r.scene, seed=seed)
    phases = Phases(sim)
    c0, w0 = time.process_time(), time.perf_counter()
    episode = spec_episode(spec, r, observer=phases)
    episode.reset(seed, sim=sim, digs=spec_digs(spec))
    res = episode.run()
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    n_ctrl = len(sim.ctrls)
    n_steps = n_ctrl * sim.substeps
    # bare MuJoCo: the same scene and number of steps, one mj_step call per block of commands
    bare = Simulation(r.robot, r.scene, seed=seed)
    block = 100  # control steps per held command
    c0 = time.process_time()
    for i in range(0, n_ctrl, block):
        bare.data.ctrl[:] = sim.ctrls[i]
        mujoco.mj_step(bare.model, bare.data, sim.substeps * min(block, n_ctrl - i))
    t_bare = time.process_time() - c0
    replay = Simulation(r.robot, r.scene, seed=seed)
    replay.soil_enabled = False
    c0 = time.process_time()
    for ctrl in sim.ctrls:
        replay.data.ctrl[:] = ctrl
        replay.step()
    t_replay = time.process_time() - c0
    planning = sum(d.planning_s for d in res.digs)
    n = len(res.digs)
    other = cpu - sim.step_s - planning - phases.scan_s
    share = lambda t: f"{t:.1f} s, {100 * t / cpu:.0f} %"  # noqa: E731
    return [
        Row("episode: CPU time", cpu, "s", f"{n} digs ({sum(d.kind != 'planned' for d in res.digs)} fallback), "
                                          f"{100 * res.removed_fraction:.0f} % removed, ended {res.end}; "
                                          f"wall {wall:.1f} s"),
        Row("episode: simulated / CPU", res.sim_time_s / cpu, "x real time",
            f"{res.sim_time_s:.0f} s simulated; wall {res.sim_time_s / wall:.1f}x", 100.0, ">="),
        Row("episode: CPU / bare MuJoCo", cpu / t_bare, "x",
            f"bare: mj_step of the same {n_steps} steps, no Python per step, {t_bare:.2f} s CPU, "
            f"{t_bare / n_steps * 1e6:.1f} us/step, {res.sim_time_s / t_bare:.0f}x real time", 3.0, "<="),
        Row("episode: commands replayed, soil off", t_replay / t_bare, "x bare",
            f"Simulation.step per control step ({n_ctrl}), no loop: {t_replay:.2f} s CPU"),
        Row("episode: stepping (MuJoCo + soil)", sim.step_s / t_bare, "x bare",
            f"Simulation.step: {share(sim.step_s)} of the episode"),
        Row("episode: scanning + mapping", phases.scan_s, "s CPU", f"{share(phases.scan_s)}; {n + 1} maps"),
        Row("episode: planning", planning, "s", f"{share(planning)} (planner's own clock)"),
        Row("episode: executor logic + settling", other, "s CPU",
            f"{share(other)}: script engine, IK, F/T per control step; settlement"),
    ]


def bench_coldstart() -> list[Row]:
    """Cold start: ``excavsim cycle`` (one dig of the default trench) in fresh processes, child CPU time:
    with an empty numba cache; after ``excavsim warmup`` filled an empty cache (what ``make`` does
    after installing, so a fresh clone's first ``make demo`` runs this way); and with a warm cache.

    Target: the first run after installing costs <= 3 s CPU more than a warm one. Without the
    warm-up, compiling costs the first run the difference printed as "without the warm-up".
    """
    import os
    import resource
    import subprocess
    import sys
    import tempfile

    def child_cpu(env: dict[str, str], *args: str) -> tuple[float, float]:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        processes.run([sys.executable, "-m", "excavsim.cli", *args], env=env, check=True,
                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime), time.perf_counter() - w0

    with tempfile.TemporaryDirectory(prefix="excavsim-numba-") as cold_dir, \
            tempfile.TemporaryDirectory(prefix="excavsim-numba-") as warm_dir:
        cold, cold_wall = child_cpu(dict(os.environ, NUMBA_CACHE_DIR=cold_dir), "cycle")
        warm, warm_wall = child_cpu(dict(os.environ, NUMBA_CACHE_DIR=cold_dir), "cycle")
        env = dict(os.environ, NUMBA_CACHE_DIR=warm_dir)
        warming, _ = child_cpu(env, "warmup")
        first, first_wall = child_cpu(env, "cycle")
    return [
        Row("cold start: cycle, empty numba cache", cold, "s CPU", f"wall {cold_wall:.1f} s"),
        Row("cold start: cycle, warm cache", warm, "s CPU", f"wall {warm_wall:.1f} s"),
        Row("cold start: compiling, without the warm-up", cold - warm, "s CPU", "cold - warm"),
        Row("cold start: excavsim warmup (make, after installing)", warming, "s CPU", "fills an empty cache"),
        Row("cold start: first cycle after the warm-up - warm", first - warm, "s CPU",
            f"first cycle {first:.1f} s CPU, wall {first_wall:.1f} s", 3.0, "<="),
    ]


def bench_campaign(*, episodes: int = 8) -> list[Row]:
    """Campaign throughput: the same campaign of ``episodes`` episodes (the sand trench, up to 6 digs,
    default scans and grid; a few seconds each) on 1 worker pinned to
    core 0 and on 2 workers pinned to cores 0 and 1 (``taskset``), wall time of each.

    Workers persist across episodes (start-up paid once per worker) and take episodes from a
    queue. Target: 2 workers >= 1.8x the throughput of 1 (only meaningful on an idle machine).
    """
    import os
    import shutil
    import subprocess
    import sys
    import tempfile

    if shutil.which("taskset") is None or (os.cpu_count() or 1) < 2:
        return [Row("campaign: 2 workers / 1", math.nan, "x", "needs taskset and 2 cores")]
    yaml = ("name: bench\nbase:\n  goal: sand\n  dig_budget: 6\n"
            f"grid:\n  seed: [{', '.join(str(i) for i in range(episodes))}]\n")

    def run(cores: str, workers: int, folder: str) -> float:
        w0 = time.perf_counter()
        processes.run(["taskset", "-c", cores, sys.executable, "-m", "excavsim.cli", "campaign", spec_path,
                       "--workers", str(workers), "--out", os.path.join(folder, f"w{workers}")], check=True,
                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        return time.perf_counter() - w0

    with tempfile.TemporaryDirectory(prefix="excavsim-bench-campaign-") as folder:
        spec_path = os.path.join(folder, "bench.yaml")
        with open(spec_path, "w", encoding="utf-8") as f:
            f.write(yaml)
        one = run("0", 1, folder)
        two = run("0,1", 2, folder)
    return [
        Row("campaign: 1 worker on core 0", one, "s wall", f"{episodes} episodes of up to 6 digs (sand trench)"),
        Row("campaign: 2 workers on cores 0-1", two, "s wall", "same episodes"),
        Row("campaign: 2 workers / 1", one / two, "x throughput", "wall; other load on the machine lowers it",
            1.8, ">="),
    ]


def bench_envs(*, copies: int = 8, steps: int = 200, seed: int = 0) -> list[Row]:
    """Throughput of the joint-level environment (``excavsim/TrenchJointDig-v0``, uniform random
    actions from the bucket's near-soil start, no episode end within the timing): one environment,
    Gymnasium's ``make_vec`` in ``sync`` and ``async`` (forkserver) modes and the batched vector
    environment (:class:`~excavsim.envs.batched.BatchedJointEnv`, the ``vector_entry_point``), each
    with ``copies`` copies stepped ``steps`` times, beside bare ``mj_step`` of the same control steps
    (the scene's substeps with the same servo rates, no soil, no observation). Steps/s from CPU time
    (this process; ``async``'s workers are not counted there, so it reports wall time) and wall time.
    Target: the batched environment at >= 50 % of bare MuJoCo's rate (issue 36). Also one
    ``excavsim/ExcavatorJoint-v0`` (the TB035 at 50 Hz) with random valves and with a dig's constant valves
    (the bucket in the soil), no target."""
    import multiprocessing

    import gymnasium as gym
    import mujoco

    import excavsim.envs  # noqa: F401 - registers the environments
    from excavsim.envs.joint_core import JointCore

    env_id = "excavsim/TrenchJointDig-v0"
    horizon = {"max_time_s": 2 * steps / 100 + 10}  # no episode ends while timed
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1, 1, (steps, copies, 4)).astype(np.float32)

    def timed(fn) -> tuple[float, float]:
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        return time.process_time() - c0, time.perf_counter() - w0

    rows: list[Row] = []

    def add(name: str, n: int, cpu: float, wall: float, note: str, cpu_valid: bool = True) -> float:
        rate_cpu, rate_wall = n / cpu if cpu_valid else math.nan, n / wall
        rows.append(Row(f"envs: {name}, steps/s (CPU)", rate_cpu, "steps/s", note))
        rows.append(Row(f"envs: {name}, steps/s (wall)", rate_wall, "steps/s", note))
        return rate_cpu if cpu_valid else rate_wall

    # bare MuJoCo: the same scene and control steps, the servos' rates of the random actions
    core = JointCore(None, **{**gym.spec(env_id).kwargs, **horizon})  # the id's goal and defaults
    core.reset(seed)
    sim = core.sim
    model, data, substeps = sim.model, sim.data, sim.substeps
    rates = actions[:, 0, :].astype(np.float64) * sim.rate_limit[:4]
    ctrl = data.ctrl
    act = sim._act[:4]

    def bare():
        for k in range(steps):
            ctrl[act] = rates[k]
            mujoco.mj_step(model, data, substeps)

    bare_cpu, bare_wall = timed(bare)
    bare_rate = add("bare mj_step", steps, bare_cpu, bare_wall, f"{substeps} substeps per control step, no soil")
    core.close()

    env = gym.make(env_id, **horizon)
    env.reset(seed=seed)
    env.step(actions[0, 0])  # warm, as the vector environments below: a fresh numba cache compiles here
    cpu, wall = timed(lambda: [env.step(actions[k, 0]) for k in range(steps)])
    env.close()
    single = add("single", steps, cpu, wall, "one TrenchJointDig-v0")

    # the excavator's joint level (the TB035 at 50 Hz): random valves, and a dig (boom down, stick in, bucket
    # curling) whose bucket is in the soil the whole time
    exc = gym.make("excavsim/ExcavatorJoint-v0", max_time_s=2 * steps / 50 + 10)
    for name, acts in (("random valves", actions[:, 0]), ("digging", np.tile(np.float32([0, -0.6, 0.5, 0.4]), (steps, 1)))):
        exc.reset(seed=seed)
        exc.step(acts[0])
        cpu, wall = timed(lambda: [exc.step(acts[k]) for k in range(steps)])
        add(f"ExcavatorJoint-v0 (TB035), {name}", steps, cpu, wall, "one environment, 10 substeps per step")
    exc.close()

    multiprocessing.set_forkserver_preload(["excavsim.envs.joint_env"])
    results = {}
    for mode, kwargs in (("sync", {}), ("async", {"vector_kwargs": {"context": "forkserver"}}), ("batched", {})):
        vmode = "vector_entry_point" if mode == "batched" else mode
        venv = gym.make_vec(env_id, num_envs=copies, vectorization_mode=vmode, **kwargs, **horizon)
        venv.reset(seed=seed)
        venv.step(actions[0])  # warm: the batched soil kernel compiles on its first call
        cpu, wall = timed(lambda: [venv.step(actions[k]) for k in range(steps)])
        venv.close()
        results[mode] = add(f"{mode} x {copies}", steps * copies, cpu, wall,
                            "wall only: the workers' CPU is not this process's" if mode == "async"
                            else f"{copies} copies", cpu_valid=mode != "async")
    rows.append(Row("envs: single / bare mj_step (CPU)", single / bare_rate, "x", "the same control steps"))
    rows.append(Row("envs: batched / bare mj_step (CPU)", results["batched"] / bare_rate, "x",
                    f"{copies} copies; target 0.5 (issue 36)", target=0.5, sense=">="))
    rows.append(Row("envs: batched / single (CPU)", results["batched"] / single, "x", "steps/s ratio"))
    return rows


BENCHMARKS: dict[str, Callable[[], list[Row]]] = {
    "step": bench_step_rate,
    "kinematics": bench_kinematics,
    "reachability": bench_reachability,
    "settle": bench_settle,
    "wedge": bench_wedge,
    "soil": bench_soil_coupling,
    "sensing": bench_sensing,
    "planner": bench_planner,
    "episode": bench_episode,
    "coldstart": bench_coldstart,
    "campaign": bench_campaign,
    "envs": bench_envs,
}


def run_benchmarks(names: list[str] | None = None, *, echo: Callable[[str], None] = print) -> list[Row]:
    """Run the named benchmarks (all when None) and print one table, each target with met or missed;
    returns its rows."""
    rows: list[Row] = []
    for name in names or list(BENCHMARKS):
        echo(f"running {name} ...")
        rows += [Row(*r) for r in BENCHMARKS[name]()]
    width = max(len(r.name) for r in rows)
    echo("")
    echo(f"{'benchmark':<{width}}  {'value':>12}  {'unit':<12} {'target':<9} {'':<6} note")
    for r in rows:
        target = "" if r.target is None else f"{r.sense} {r.target:g}"
        verdict = {None: "", True: "met", False: "MISSED"}[r.met]
        echo(f"{r.name:<{width}}  {r.value:12.4g}  {r.unit:<12} {target:<9} {verdict:<6} {r.note}")
    targets = [r for r in rows if r.met is not None]
    if targets:
        echo(f"\ntargets: {sum(bool(r.met) for r in targets)} of {len(targets)} met"
             + "".join(f"; missed: {r.name} ({r.value:.3g} {r.unit}, target {r.sense} {r.target:g})"
                       for r in targets if not r.met))
    return rows
