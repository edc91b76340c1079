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
import dataclasses
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
from typing import Any

import yaml

from excavsim.errors import ExcavsimError
from excavsim.handoff.episode import EpisodeObserver
from excavsim.loop.campaign_grid import (OVERRIDE_SECTIONS, CampaignSpec, Episode, check_campaign, episode_id,
                                         expand_grid, load_campaign, parse_campaign)
from excavsim.loop.campaign_report import (format_table, group_table, plot_campaign, summary_rows, write_atomic,
                                           write_tables)
from excavsim.loop.scenario import EpisodeSpec, dig_rows, episode_summary, run_spec

__all__ = ["OVERRIDE_SECTIONS", "CampaignReport", "CampaignSpec", "Episode", "check_campaign", "episode_id",
           "expand_grid", "load_campaign", "parse_campaign", "run_campaign", "run_episode_task"]

# Makes the observer that records one episode to the given path (excavsim.record.RerunRecorder).
Recorder = Callable[[pathlib.Path], EpisodeObserver]


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


def _task(ep: Episode, out_dir: pathlib.Path, recorder: Recorder | None) -> dict[str, Any]:
    return {"id": ep.id, "name": ep.name, "params": ep.params, "spec": ep.spec.model_dump(mode="json"),
            "out_dir": str(out_dir.resolve()), "recording": f"recordings/{ep.id}.rrd" if recorder else None,
            "recorder": recorder}


def run_episode_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one campaign episode (in a worker) and return its result record; never raises.

    Args:
        task: ``id``, ``name``, ``params``, ``spec`` (an EpisodeSpec as JSON), ``out_dir``,
            ``recording`` (a path under ``out_dir``, or None) and ``recorder`` (the observer factory
            that records to that path, or None).

    Returns:
        A JSON-ready record: the task's fields, ``status`` (``ok`` or ``error``), ``summary`` (see
        :func:`~excavsim.loop.scenario.episode_summary`), ``digs`` (one row per dig,
        :func:`~excavsim.loop.scenario.dig_rows`), ``error`` and ``traceback`` when the
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
        if task["recording"] and task.get("recorder") is not None:
            path = pathlib.Path(task["out_dir"]) / task["recording"]
            path.parent.mkdir(parents=True, exist_ok=True)
            observer = task["recorder"](path)
        result = run_spec(spec, progress=log.append, observer=observer)
        rec["summary"], rec["digs"] = episode_summary(result), dig_rows(result)
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
                 resume: bool = False, ray_address: str | None = None, recorder: Recorder | None = None,
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
        recorder: what records an episode with ``record: true``: called in the worker with the
            recording's path, it returns the episode's observer (the CLI hands
            :class:`excavsim.record.RerunRecorder`); it must be picklable (a class or a module-level
            function), since it travels to the worker processes.
        progress: receives one line per finished episode (count, result, ETA) and the summary.

    Raises:
        ConfigError: the grid is invalid.
        ExcavsimError: ``out_dir`` holds results and ``resume`` is false, it is in use by another run,
            ``workers`` is below 1, Ray is missing or unreachable, ``record: true`` without a
            ``recorder``, or a worker process died.
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
        if spec.record and todo and recorder is None:
            raise ExcavsimError(f"campaign {spec.name} has record: true but no recorder was given: pass "
                                "recorder=excavsim.record.RerunRecorder (the CLI does)")
        write_atomic(out / "campaign.yaml", yaml.safe_dump(spec.model_dump(mode="json"), sort_keys=False))

        n = min(workers or os.cpu_count() or 1, max(len(todo), 1))
        where = f"Ray ({ray_address})" if ray_address else f"{n} local process{'es' if n > 1 else ''}"
        say(f"campaign {spec.name}: {len(episodes)} episodes, {len(episodes) - len(todo)} already done, "
            f"{len(todo)} to run on {where}; results in {out}")
        tasks = [_task(e, out, recorder if spec.record else None) for e in todo]
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
        for keys in spec.report_by:
            say(f"\nby {', '.join(keys)}:\n" + group_table(rows, keys, ep_dir))
        say("wrote " + ", ".join(str(p) for p in [*tables, *plots]))
    return CampaignReport(out, episodes, ran, rows, plots)
