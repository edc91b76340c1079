"""Trenching campaigns: many episodes over a grid of parameters, run in parallel and resumable.

A campaign YAML (:class:`CampaignSpec`) names a base :class:`~excavsim.loop.scenario.EpisodeSpec`
and a grid of dotted keys, each with a list of values; the cartesian product of the grid gives the
episodes::

    name: wrist-vs-soil
    base: {goal: sand, dig_budget: 12}
    grid:
      soil: [testbed_sand, lean_clay]
      robot.joints.wrist_pitch.torque_limit_nm: [500, 1000]
      seed: [0, 1]

:func:`run_campaign` runs the episodes on local processes (or on Ray) and writes, under its output
directory: ``campaign.yaml`` (the validated specification), ``episodes/<id>.json`` (one per episode,
written atomically as it finishes), ``recordings/<id>.rrd`` (with ``record: true``), then
``summary.csv`` (and ``summary.parquet`` when pyarrow is installed) and ``plots/*.png``. An episode's
id is its grid values and a hash of its specification, so an interrupted campaign is finished by
running again with ``resume=True``: only episodes without a result file run.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import itertools
import json
import math
import multiprocessing
import numbers
import os
import pathlib
import socket
import time
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import Annotated, Any

import yaml
from pydantic import Field

from excavsim.config import _Strict, load_config, parse_config
from excavsim.errors import ConfigError, ExcavsimError
from excavsim.loop.campaign_report import format_table, plot_campaign, slug, summary_rows, write_atomic, write_tables
from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec, episode_summary, merge, resolve_goal, run_spec

OVERRIDE_SECTIONS = ("robot", "scene", "planner", "executor", "sensing")


class CampaignSpec(_Strict):
    """A campaign: a base episode and a grid of parameters whose cartesian product gives the episodes."""

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
                      description="label of the campaign and of its default output directory")
    base: EpisodeSpec = Field(default_factory=EpisodeSpec, description="what every episode shares")
    grid: dict[str, Annotated[list[Any], Field(min_length=1)]] = Field(
        default_factory=dict,
        description="dotted keys of EpisodeSpec (e.g. seed, soil, robot.joints.wrist_pitch.torque_limit_nm, "
                    "goal.depth_m) to the values they take")
    record: bool = Field(default=False, description="write a Rerun recording per episode (recordings/<id>.rrd)")


@dataclasses.dataclass(frozen=True)
class Episode:
    """One point of a campaign's grid: its stable id, readable name, grid values and full specification."""

    id: str
    name: str
    params: dict[str, Any]
    spec: EpisodeSpec


@dataclasses.dataclass
class CampaignReport:
    """What :func:`run_campaign` did: the episodes, how many ran now, and one summary row per episode."""

    out_dir: pathlib.Path
    episodes: list[Episode]
    ran: int
    rows: list[dict[str, Any]]
    plots: list[pathlib.Path]

    @property
    def errors(self) -> int:
        """Episodes whose status is not ``ok``."""
        return sum(r["status"] != "ok" for r in self.rows)


# -- the grid -----------------------------------------------------------------------------------------
def _nested(path: list[str], value: Any) -> dict:
    for part in reversed(path):
        value = {part: value}
    return value


def _apply(data: dict, key: str, value: Any) -> None:
    """Set the dotted ``key`` of episode-spec ``data`` (a model dump) to ``value``, in place."""
    head, *rest = key.split(".")
    if head == "name":
        raise ConfigError("grid key 'name': episode names are made from their grid values; vary another field")
    if head not in EpisodeSpec.model_fields:
        raise ConfigError(f"grid key {key!r}: {head!r} is not an episode field; allowed: "
                          f"{', '.join(f for f in EpisodeSpec.model_fields if f != 'name')} "
                          f"(goal and {', '.join(OVERRIDE_SECTIONS)} take dotted keys into their fields)")
    if not rest:
        data[head] = value
    elif head == "goal":
        goal = data["goal"] if isinstance(data["goal"], dict) else resolve_goal(data["goal"]).model_dump()
        data["goal"] = merge(goal, _nested(rest, value), where="goal.")
    elif head in OVERRIDE_SECTIONS:
        data[head] = merge(data[head], _nested(rest, value), where=f"{head}.")
    else:
        raise ConfigError(f"grid key {key!r}: {head} takes a single value; write {head!r} without a dotted suffix")


def episode_id(spec: EpisodeSpec, params: dict[str, Any]) -> str:
    """A stable, file-name-safe id: the grid values (numbers after their key), then a hash of the spec.

    The hash covers the canonical JSON of ``spec`` without its name and without fields left at their
    defaults (so a new EpisodeSpec field does not change the ids of older campaigns).
    """
    canonical = json.dumps(spec.model_dump(mode="json", exclude={"name"}, exclude_defaults=True),
                           sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:10]
    parts = [v if isinstance(v, str) else f"{k.rsplit('.', 1)[-1]}{json.dumps(v)}" for k, v in params.items()]
    label = "-".join(slug(p) for p in parts) if params else slug(spec.name)
    label = label[:60].strip("-_.")
    return f"{label}-{digest}" if label else digest


def expand_grid(spec: CampaignSpec) -> list[Episode]:
    """The campaign's episodes: the cartesian product of the grid over the base, in grid order.

    Raises:
        ConfigError: a grid key or value makes an invalid EpisodeSpec, or two points give the same episode.
    """
    keys = list(spec.grid)
    base = spec.base.model_dump()
    episodes: list[Episode] = []
    seen: dict[str, str] = {}
    for values in itertools.product(*(spec.grid[k] for k in keys)):
        params = dict(zip(keys, values))
        data = copy.deepcopy(base)
        for key, value in params.items():
            _apply(data, key, value)
        name = " ".join(f"{k}={slug(v)}" for k, v in params.items()) or spec.base.name
        data["name"] = name
        ep = parse_config(data, EpisodeSpec, source=f"campaign {spec.name}: episode {name}")
        eid = episode_id(ep, params)
        if eid in seen:
            raise ConfigError(f"campaign {spec.name}: the grid gives the same episode twice ({seen[eid]!r} and "
                              f"{name!r}); remove the repeated value")
        seen[eid] = name
        episodes.append(Episode(eid, name, params, ep))
    return episodes


def check_campaign(spec: CampaignSpec, *, source: str) -> list[Episode]:
    """Validate every grid value against the configurations it overrides; returns the episodes.

    Each value is checked alone on the base (so the message names the key and the value); values
    that are only invalid together surface when their episode runs, as an episode error.

    Raises:
        ConfigError: naming ``source``, the grid key, the value and what is wrong.
    """
    try:
        ResolvedSpec(spec.base)
    except ConfigError as exc:
        raise ConfigError(f"{source}: base: {exc}") from None
    base = spec.base.model_dump()
    for key, values in spec.grid.items():
        for value in values:
            try:
                data = copy.deepcopy(base)
                _apply(data, key, value)
                ResolvedSpec(parse_config(data, EpisodeSpec, source=f"grid {key}"))
            except ConfigError as exc:
                raise ConfigError(f"{source}: grid key {key!r}, value {value!r}:\n  {exc}") from None
    try:
        return expand_grid(spec)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def parse_campaign(data: Any, *, source: str = "campaign") -> CampaignSpec:
    """Validate an already-parsed campaign mapping, grid included (see :func:`load_campaign`)."""
    spec = parse_config(data, CampaignSpec, source=source)
    check_campaign(spec, source=source)
    return spec


def load_campaign(path: str | pathlib.Path) -> CampaignSpec:
    """Read and validate a campaign YAML file, grid included.

    Raises:
        ConfigError: the file, the field or grid key, the value and what is allowed.
    """
    spec = load_config(path, CampaignSpec)
    check_campaign(spec, source=str(path))
    return spec


# -- one episode, in a worker --------------------------------------------------------------------------
def _json_safe(obj: Any) -> Any:
    """``obj`` with non-finite floats as None and numpy scalars as Python numbers (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, numbers.Integral):
        return int(obj)
    if isinstance(obj, numbers.Real):
        return float(obj) if math.isfinite(obj) else None
    return str(obj)


def _task(ep: Episode, out_dir: pathlib.Path, record: bool) -> dict[str, Any]:
    return {"id": ep.id, "name": ep.name, "params": ep.params, "spec": ep.spec.model_dump(mode="json"),
            "out_dir": str(out_dir.resolve()), "recording": f"recordings/{ep.id}.rrd" if record else None}


def run_episode_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one campaign episode (in a worker) and return its result record; never raises.

    Args:
        task: ``id``, ``name``, ``params``, ``spec`` (an EpisodeSpec as JSON), ``out_dir`` and
            ``recording`` (a path under ``out_dir``, or None).

    Returns:
        A JSON-ready record: the task's fields, ``status`` (``ok`` or ``error``), ``summary`` (see
        :func:`~excavsim.loop.scenario.episode_summary`), ``error`` and ``traceback`` when the
        episode raised, the episode's ``log`` lines, ``wall_s``, ``host`` and ``pid``.
    """
    log: list[str] = []
    rec = {k: task[k] for k in ("id", "name", "params", "spec", "recording")}
    rec.update(status="ok", summary=None, error=None, traceback=None, log=log, host=socket.gethostname(),
               pid=os.getpid())
    t0 = time.perf_counter()
    try:
        spec = EpisodeSpec.model_validate(task["spec"])
        observer = None
        if task["recording"]:
            from excavsim.record import RerunRecorder  # only when recording: rerun is heavy

            path = pathlib.Path(task["out_dir"]) / task["recording"]
            path.parent.mkdir(parents=True, exist_ok=True)
            observer = RerunRecorder(path)
        rec["summary"] = episode_summary(run_spec(spec, progress=log.append, observer=observer))
    except Exception as exc:  # noqa: BLE001 - a failing episode is a result, not the campaign's end
        rec.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
    rec["wall_s"] = time.perf_counter() - t0
    return _json_safe(rec)


# -- backends: each yields result records as episodes finish -------------------------------------------
def _local_results(tasks: list[dict], workers: int) -> Iterator[dict]:
    # MuJoCo and numba are not fork-safe: workers start from a clean interpreter.
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(method))
    try:
        futures = [pool.submit(run_episode_task, t) for t in tasks]
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except BrokenProcessPool:
                raise ExcavsimError("a worker process died (killed, out of memory or crashed in native code); "
                                    "the results so far are saved: run again with --resume to finish") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _import_ray():
    try:
        import ray
    except ImportError:
        ray = None
    if not hasattr(ray, "remote"):  # missing, or a bare ``ray/`` folder (Ray's /tmp/ray) seen as a namespace
        raise ExcavsimError("running a campaign on Ray needs Ray, an optional extra: pip install 'excavsim[ray]' "
                            "(or run without --ray on local processes)")
    return ray


def _ray_results(tasks: list[dict], address: str, workers: int | None) -> Iterator[dict]:
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        try:
            if address == "local":
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise ExcavsimError(f"cannot start or reach Ray at {address!r}: {exc}; give 'local' for a "
                                "cluster on this machine, 'auto' or HOST:PORT for a running one") from None
    remote = ray.remote(num_cpus=1, max_retries=1)(run_episode_task)
    pending = {remote.remote(t): t for t in tasks}
    try:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                task = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as exc:  # the worker died; the task itself never raises
                    yield _json_safe({**{k: task[k] for k in ("id", "name", "params", "spec", "recording")},
                                      "status": "error", "summary": None, "error": f"Ray: {exc}",
                                      "traceback": None, "log": [], "wall_s": None})
    finally:
        for ref in pending:
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)
        if started:
            ray.shutdown()


# -- files ---------------------------------------------------------------------------------------------
@contextlib.contextmanager
def _exclusive(out: pathlib.Path) -> Iterator[None]:
    """Hold ``out/.lock`` so that two runs never share an output directory (released if the process dies)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(out / ".lock", "w") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ExcavsimError(f"{out} is in use by another campaign run; wait for it to end or choose "
                                "another --out directory") from None
        yield


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600} h {s % 3600 // 60:02d} min" if s >= 3600 else f"{s // 60} min {s % 60:02d} s"


def _progress_line(count: int, total: int, rec: dict, eta_s: float) -> str:
    head = f"[{count}/{total}] {rec['id']}:"
    if rec["status"] != "ok":
        text = f"{head} ERROR {str(rec['error']).splitlines()[0][:200]}"
    else:
        s = rec["summary"]

        def num(key: str, scale: float = 1.0, fmt: str = ".1f") -> str:  # None: not finite in the episode
            return "?" if s.get(key) is None else format(scale * s[key], fmt)

        text = (f"{head} {s['end']} after {s['digs']} digs, {num('dug_l_per_dig')} l/dig, "
                f"{num('removed_fraction', 100.0, '.0f')} % removed ({rec['wall_s']:.0f} s)")
    return f"{text}; ETA {_duration(eta_s)}" if count < total else text


# -- the campaign --------------------------------------------------------------------------------------
def run_campaign(spec: CampaignSpec, out_dir: str | pathlib.Path, *, workers: int | None = None,
                 resume: bool = False, ray_address: str | None = None,
                 progress: Callable[[str], None] | None = print) -> CampaignReport:
    """Run the campaign's episodes in parallel, then write its summary table and plots.

    Args:
        spec: the campaign.
        out_dir: where results go (created; see the module docstring for the layout).
        workers: local processes (default ``os.cpu_count()``); with Ray on this machine, its CPUs.
        resume: run only the episodes without a result file in ``out_dir``; without it an
            ``out_dir`` that holds results is refused.
        ray_address: None for local processes; ``"local"`` for a Ray instance started here,
            ``"auto"`` or ``HOST:PORT`` for a running Ray cluster (needs a shared ``out_dir`` only
            when recording).
        progress: receives one line per finished episode (count, result, ETA) and the summary.

    Raises:
        ConfigError: the grid is invalid.
        ExcavsimError: ``out_dir`` holds results and ``resume`` is false, it is in use by another run,
            ``workers`` is below 1, Ray is missing or unreachable, or a worker process died.
    """
    say = progress or (lambda _s: None)
    if workers is not None and workers < 1:
        raise ExcavsimError(f"workers must be at least 1; given {workers}")
    if ray_address:
        _import_ray()
    episodes = check_campaign(spec, source=f"campaign {spec.name}")
    out = pathlib.Path(out_dir)
    ep_dir = out / "episodes"
    ep_dir.mkdir(parents=True, exist_ok=True)
    with _exclusive(out):
        for tmp in ep_dir.glob(".*.tmp"):  # writes cut short by a kill
            tmp.unlink()
        done = {p.stem for p in ep_dir.glob("*.json")}
        if done and not resume:
            raise ExcavsimError(f"{out} already holds {len(done)} episode result(s); run with --resume to run "
                                "only the missing episodes, or choose another --out directory")
        ids = {e.id for e in episodes}
        if stale := done - ids:
            say(f"note: {len(stale)} result file(s) in {ep_dir} are not episodes of this campaign "
                "(an earlier grid?); the summary leaves them out")
        todo = [e for e in episodes if e.id not in done]
        if spec.record and todo:
            try:
                import excavsim.record  # noqa: F401
            except ImportError as exc:
                raise ExcavsimError(f"record: true needs the Rerun recorder (excavsim.record): {exc}") from None
        write_atomic(out / "campaign.yaml", yaml.safe_dump(spec.model_dump(mode="json"), sort_keys=False))

        n = min(workers or os.cpu_count() or 1, max(len(todo), 1))
        where = f"Ray ({ray_address})" if ray_address else f"{n} local process{'es' if n > 1 else ''}"
        say(f"campaign {spec.name}: {len(episodes)} episodes, {len(episodes) - len(todo)} already done, "
            f"{len(todo)} to run on {where}; results in {out}")
        tasks = [_task(e, out, spec.record) for e in todo]
        results = _ray_results(tasks, ray_address, workers) if ray_address else _local_results(tasks, n)
        count, ran, t0 = len(episodes) - len(todo), 0, time.perf_counter()
        try:
            for rec in results if tasks else ():
                write_atomic(ep_dir / f"{rec['id']}.json", json.dumps(rec, indent=1, allow_nan=False) + "\n")
                count, ran = count + 1, ran + 1
                eta = (time.perf_counter() - t0) / ran * (len(todo) - ran)
                say(_progress_line(count, len(episodes), rec, eta))
        except KeyboardInterrupt:
            say(f"interrupted: {count} of {len(episodes)} results saved in {ep_dir}; run again with --resume")
            raise
        finally:
            results.close()
        rows = summary_rows(episodes, ep_dir)
        tables = write_tables(rows, out, progress=say)
        plots = plot_campaign(spec, rows, out / "plots")
        say(format_table(spec, rows))
        say("wrote " + ", ".join(str(p) for p in [*tables, *plots]))
    return CampaignReport(out, episodes, ran, rows, plots)
