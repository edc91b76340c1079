"""The digs a calibration fits and re-runs: recording them, reading them back, digging them again.

:func:`record_digs` digs random feasible digs in one soil box (one episode, ``excavsim calibrate
--record-digs N``) and saves their force record (:class:`~excavsim.learning.dataset.ForceDataset`)
with, in its metadata, what the robot measured of each dig besides the forces: the soil the scans
saw the dig remove (:func:`removed_volume`, the map before less the map after, around the dig) and
the action. Another observer (the CLI's Rerun recorder) may watch the same episode.

:func:`dataset_from_recording` turns what :func:`excavsim.record.reading.read_recording` read out of a
Rerun recording (F/T in the tip frame, joint angles, the scanned maps, the plans in the log) into
the same record, with the robot's own kinematics and the maps: nothing of the world's truth.

:func:`rerun_digs` digs the recorded actions again, in the same order and with the same seed, in a
world whose soil is a fitted preset, and returns that record: the calibration's predicted forces
from MuJoCo and the soil model instead of the fitted formula.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from typing import Any

import numpy as np

from excavsim import constants
from excavsim.config import parse_config
from excavsim.errors import ConfigError, DataFileError, ExcavsimError, UsageError
from excavsim.handoff.episode import EpisodeObserver, ObserverGroup
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.dataset import ForceDataset, path_progress
from excavsim.learning.encoding import Terrain, encode
from excavsim.rig.samples import DigSamples

# The band around a dig's path where the scans count the soil it removed: the settlement after the
# dig moves soil only within it, the spoil lands outside it (measured: the removed volume within
# 2 % of the load at 0.25-0.4 m, 3-4 digs of the testbed sand).
DIGS_SPEC = constants.CONFIGS_DIR / "specs" / "calibration_digs.yaml"
"""The episode the calibration's digs are dug in (its task, machine and goal; seed, soil and truth are set here)."""
RIM_ACROSS_M = 0.3  # beyond the bucket's half width, across the arm plane
RIM_ALONG_M = 0.4  # beyond the path's radial extent
# quiet records: no rate effect, failure-cycle drops, heterogeneity or the F/T reading's digging disturbance
QUIET = {"cohesion_rate_per_decade": 0.0, "brittleness_index": 0.0, "heterogeneity_std": 0.0,
         "ft_dig_noise_share": 0.0}


def removed_volume(before: ElevationMap, after: ElevationMap, path_xz: np.ndarray, arm, waist: float,
                   width: float) -> float:
    """Soil the scans saw a dig remove [m^3]: ``before - after`` summed over the cells within
    ``RIM_ACROSS_M`` of the bucket's edges and ``RIM_ALONG_M`` of the path's radial extent.

    Args:
        before, after: the maps scanned before and after the dig (one grid).
        path_xz: (n, 2) the tip's path in the arm plane [m].
        arm: the :class:`~excavsim.robot.kinematics.PlanarArm`; waist: the arm plane [rad]; width [m].
    """
    if before.heights.shape != after.heights.shape:
        raise UsageError(f"maps of different grids: {before.heights.shape} and {after.heights.shape}")
    xc, yc = before.centres()
    gx, gy = np.meshgrid(xc, yc)
    o, e1 = arm.plane_to_world(waist, np.array([[0.0, 0.0], [1.0, 0.0]]))
    along = (e1 - o)[:2] / np.linalg.norm((e1 - o)[:2])
    r = (gx - o[0]) * along[0] + (gy - o[1]) * along[1]
    lat = -(gx - o[0]) * along[1] + (gy - o[1]) * along[0]
    x = np.asarray(path_xz, dtype=float)[:, 0]
    band = (np.abs(lat) < width / 2 + RIM_ACROSS_M) & (r > x.min() - RIM_ALONG_M) & (r < x.max() + RIM_ALONG_M)
    return float((before.heights - after.heights)[band].sum() * before.cell**2)


class _DigRecorder(DigSamples):
    """Keeps the rows of every dig, the maps, and each dig's removed volume and action."""

    def __init__(self, say: Callable[[str], None]):
        self.parts: list[ForceDataset] = []
        self.volumes: dict[int, float] = {}
        self.actions: dict[int, list[float]] = {}
        self.say = say
        self._maps: list[ElevationMap] = []
        self._pending: tuple[int, np.ndarray] | None = None

    def scanned(self, index: int, emap, accuracy) -> None:
        super().scanned(index, emap, accuracy)
        if self._pending is not None and self._maps:
            k, path = self._pending
            self.volumes[k] = removed_volume(self._maps[-1], emap, path, self.rig.arm, self.waist, self.rig.width)
            self._pending = None
        self._maps.append(emap)

    def dug(self, index: int, record, metrics) -> None:
        rows = self.rows(record, len(self.parts))
        rows = ForceDataset.empty() if rows is None else rows
        k = len(self.parts)
        self.parts.append(rows)
        if record.executed_path:
            self._pending = (k, np.asarray(record.executed_path)[:, :2])
        if metrics.action is not None:
            self.actions[k] = [float(a) for a in metrics.action]
        self.say(f"dig {k + 1}: {record.outcome}, {len(rows)} samples")


def record_digs(path, *, truth: str = "wedge", soil: str | None = None, digs: int = 3, seed: int = 0,
                quiet: bool = False, observer: EpisodeObserver | None = None,
                say: Callable[[str], None] | None = None) -> ForceDataset:
    """Dig ``digs`` random feasible digs (one episode, seed ``seed``) on the ``truth`` model and save
    their force record at ``path``; returns it.

    ``quiet``: the wedge's truth terms (rate effect, failure-cycle drops, heterogeneity) off, so that the record is
    of a known soil. The metadata names the truth, the soil, the seed, the bucket width, and per dig
    the action (``actions``) and the soil the scans saw it remove (``removed_m3``), as JSON.
    ``observer``: another observer of the episode (a Rerun recorder).

    Raises:
        ExcavsimError: ``digs`` below 1, or no feasible dig in the fresh box.
    """
    from excavsim.world.simulation import Simulation

    if digs < 1:
        raise ConfigError(f"record_digs needs digs >= 1; given {digs}")
    t: dict[str, Any] = {"model": truth, **(QUIET if quiet else {})}
    spec, cfg = _digs_spec("calibrate", seed, t, soil=soil, budget=digs)
    sim = Simulation(cfg.robot, cfg.scene, seed=seed)
    rec = _DigRecorder(say or (lambda _s: None))
    _dig(sim, spec, cfg, spec.plugin.dig_source("random", np.random.default_rng((seed, 8)), 0.3),
         ObserverGroup(rec, observer))
    if not any(len(p) for p in rec.parts):
        raise ExcavsimError(f"no dig of {sim.scene.soil} gave force samples (seed {seed})")
    data = ForceDataset.concat(rec.parts, meta=_meta(truth, sim.scene.soil, seed, quiet, rec.rig.width, rec.actions,
                                                     rec.volumes))
    data.save(path)
    return data


def _digs_spec(name: str, seed: int, truth: dict[str, Any], *, soil: str | None = None, budget: int = 1):
    """The specification of the calibration's digs (:data:`DIGS_SPEC`, whose task digs them: an application
    names no task) with ``name``, ``seed``, ``soil``, the world's ``truth`` and a budget of ``budget`` digs, and
    its resolved configurations."""
    from excavsim.loop.scenario import EpisodeSpec, load_spec, merge, resolve

    base = load_spec(DIGS_SPEC)
    data = base.model_dump()
    data.update(name=name, seed=seed, soil=soil, dig_budget=budget,
                scene=merge(data.get("scene", {}), {"truth": truth}))
    spec = parse_config(data, EpisodeSpec, source=str(DIGS_SPEC))
    return spec, resolve(spec)


def _dig(sim, spec, cfg, digs, observer: EpisodeObserver) -> None:
    """The episode of ``spec`` (its task's, through the platform's catalog: an application imports no task) in
    ``sim`` with the configurations ``cfg``, its budget of digs from the dig source ``digs`` (the spec digs for
    data: no early stop)."""
    episode = spec.plugin.episode(spec, cfg, observer=observer)
    episode.reset(spec.seed, sim=sim, digs=digs)
    episode.run()


def _meta(truth: str, soil: str, seed: int, quiet: bool, width: float, actions: dict, volumes: dict) -> dict[str, str]:
    return {"truth": truth, "soil": soil, "seed": str(seed), "quiet": str(bool(quiet)).lower(),
            "bucket_width_m": repr(float(width)), "source": "excavsim.apps.calibrate.digs",
            "actions": json.dumps({str(k): v for k, v in actions.items()}),
            "removed_m3": json.dumps({str(k): v for k, v in volumes.items()})}


def removed_volumes(data: ForceDataset) -> dict[int, float]:
    """The per-dig removed volumes of a record's metadata [m^3] (empty when it has none)."""
    raw = json.loads(data.meta.get("removed_m3", "{}") or "{}")
    return {int(k): float(v) for k, v in raw.items()}


def recorded_actions(data: ForceDataset) -> list[tuple[float, float, float, float]]:
    """Each dig's action ``(k, alpha, d1, d2)`` [m, rad, m, m], from the metadata or else from the
    columns (``k``, ``alpha`` and the largest ``s1``, ``s2`` of the dig)."""
    raw = json.loads(data.meta.get("actions", "{}") or "{}")
    out = []
    for k in np.unique(data["dig"]).astype(int):
        if str(k) in raw:
            out.append(tuple(float(a) for a in raw[str(k)]))
            continue
        m = data["dig"] == k
        out.append((float(data["k"][m][0]), float(data["alpha"][m][0]), float(np.nanmax(data["s1"][m])),
                    float(np.nanmax(data["s2"][m]))))
    return out


def rerun_digs(data: ForceDataset, soil_params, *, truth: str, quiet: bool, seed: int,
               say: Callable[[str], None] | None = None) -> ForceDataset:
    """Dig the record's actions again, in order, in a fresh box of ``soil_params`` (a
    :class:`~excavsim.config.SoilParams`) on the ``truth`` model with the episode seed ``seed``;
    the re-run's force record (its digs numbered as the record's)."""
    from excavsim.world.simulation import Simulation

    t: dict[str, Any] = {"model": truth, **(QUIET if quiet else {})}
    actions = recorded_actions(data)
    spec, cfg = _digs_spec("calibrate-rerun", seed, t, budget=len(actions))
    sim = Simulation(cfg.robot, cfg.scene, soil=soil_params, seed=seed)
    rec = _DigRecorder(say or (lambda _s: None))
    _dig(sim, spec, cfg, spec.plugin.dig_source("scripted", actions), rec)
    return ForceDataset.concat(rec.parts, meta={"source": "excavsim.apps.calibrate.digs.rerun_digs"})


# -- a Rerun recording as a record ----------------------------------------------------------------

_PLAN = re.compile(r"plan (\d+): k ([-\d.]+) m, alpha ([-\d.]+) deg, d1 ([-\d.]+) m, d2 ([-\d.]+) m")
_DUG = re.compile(r"dig (\d+) \(")
AFTER_S = 1.5  # a dig's samples run this long after the tip last left the mapped surface [s]


def dataset_from_recording(rec: dict[str, Any], *, arm, waist: float, width: float, epsilon: float,
                           planner) -> ForceDataset:
    """A force record from a read recording (:func:`excavsim.record.reading.read_recording`).

    Dig ``k`` is planned at the ``plan k:`` log line and ends at the ``dig k`` line; its samples are
    the F/T readings from the touch-down's contact (the lowest point of the tip's first descent
    below the map scanned before it, the tip from the joint angles through ``arm``: where the
    executor's dig step starts), to ``AFTER_S`` after the tip last left the map's surface (the
    load's weight, lifted). The
    swept volume and the progress along the path are computed as for a live record, the path
    re-planned from the logged action on that map (``planner``: the trench planner).

    Raises:
        ExcavsimError: the recording has no F/T samples, no scans or no logged dig.
    """
    from excavsim.handoff.dig import TrenchAction

    ft_t, ft = rec["ft_time"], rec["ft_tip"]
    if ft_t.size == 0:
        raise DataFileError("the recording has no F/T samples in the tip frame (ft/tip/*): it was not recorded "
                            "by `excavsim trench --record` or `excavsim calibrate --record-digs N --rrd FILE`")
    if not rec["maps"]:
        raise DataFileError("the recording has no scanned maps (world/soil/scan)")
    plans = [(t, _PLAN.match(s)) for t, s in rec["log"] if _PLAN.match(s)]
    ends = {int(m.group(1)): t for t, s in rec["log"] if (m := _DUG.match(s))}
    if not plans:
        raise DataFileError("the recording's log names no planned trenching dig ('plan k: k .. m, alpha ..')")
    q_t, q = rec["joint_time"], np.radians(rec["joint_deg"])
    parts, actions, volumes = [], {}, {}
    maps = rec["maps"]  # (time, ElevationMap) in time order
    for t_plan, m in plans:
        index = int(m.group(1))
        t_end = ends.get(index, math.inf)
        before = [e for tm, e in maps if tm <= t_plan]
        after = [e for tm, e in maps if tm >= t_end]
        if not before:
            continue
        emap = before[-1]
        k = len(parts)
        action = TrenchAction(float(m.group(2)), math.radians(float(m.group(3))), float(m.group(4)),
                              float(m.group(5)))
        actions[k] = [float(a) for a in action]
        surface = planner.surface(emap)
        poses, phases = planner.trajectory(action, surface)
        terrain = Terrain.from_map(emap, arm, waist, width)
        sel = (ft_t > t_plan) & (ft_t < t_end)
        jsel = (q_t > t_plan) & (q_t < t_end)
        if sel.sum() < 2 or jsel.sum() < 2:
            continue
        times = ft_t[sel]
        qs = np.stack([np.interp(times, q_t[jsel], q[jsel, j]) for j in range(q.shape[1])], axis=-1)
        tip = arm.forward(qs[:, 1:4])
        below = terrain.elevation(tip[:, 0]) > tip[:, 1]
        if not below.any():
            continue
        i0 = int(np.argmax(below))
        while i0 + 1 < times.size and tip[i0 + 1, 1] < tip[i0, 1]:  # down to the touch-down's contact
            i0 += 1
        i1 = int(np.flatnonzero(below)[-1])
        keep = np.arange(times.size) >= i0
        keep &= times <= times[i1] + AFTER_S
        times, tip, forces = times[keep], tip[keep], ft[sel][keep]
        # swept volume along the (10 Hz) joint trace, as samples_from_record does along the dense one
        dense_t = q_t[jsel]
        dense = arm.forward(q[jsel][:, 1:4])
        dense = dense[dense_t >= times[0]]
        xm = 0.5 * (dense[1:, 0] + dense[:-1, 0])
        zm = 0.5 * (dense[1:, 1] + dense[:-1, 1])
        steps = np.maximum(terrain.elevation(xm) - zm, 0.0) * np.abs(np.diff(dense[:, 0])) * width
        vcum = np.concatenate([[0.0], np.cumsum(steps)])
        t_dense = dense_t[dense_t >= times[0]]
        volume = np.interp(times, t_dense, vcum) if t_dense.size > 1 else np.zeros(times.size)
        progress = path_progress(tip, poses, phases, epsilon)
        cols = encode(tip, progress, volume, terrain)
        cols.update(dig=np.full(times.size, float(k)), t=times, fx=forces[:, 0], fz=forces[:, 2])
        parts.append(ForceDataset(cols))
        if after:
            volumes[k] = removed_volume(emap, after[0], tip[:, :2], arm, waist, width)
    if not parts:
        raise DataFileError("no logged dig of the recording has F/T samples with the tip below the scanned surface")
    return ForceDataset.concat(parts, meta=_meta("unknown", rec.get("soil", "unknown"), int(rec.get("seed", 0)),
                                                 False, width, actions, volumes))


def recording_dataset(rec: dict[str, Any]) -> ForceDataset:
    """:func:`dataset_from_recording` with the robot's kinematics, the planner and the trench of the
    recording's configuration (its goal's waist angle; the default scene's arm and bucket)."""
    from excavsim.rig.core import make_rig
    from excavsim.world.simulation import Simulation

    sim = Simulation(seed=0)
    rig = make_rig(sim)
    goal = (rec.get("config") or {}).get("goal") or {}
    waist = math.radians(float(goal.get("waist_deg", rig.goal.waist_deg)))
    data = dataset_from_recording(rec, arm=rig.arm, waist=waist, width=rig.width,
                                  epsilon=math.radians(rig.planner_cfg.epsilon_deg), planner=rig.planner)
    scene = (rec.get("config") or {}).get("scene") or {}
    truth = (scene.get("truth") or {})
    data.meta["truth"] = str(truth.get("model", "unknown"))
    quiet = all(float(truth.get(k, 1.0)) == 0.0 for k in QUIET)
    data.meta["quiet"] = str(quiet).lower()
    return data
