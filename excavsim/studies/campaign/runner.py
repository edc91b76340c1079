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
running again with ``resume=True``: only episodes without a valid result file run.

Hygiene, since campaigns run unattended: a result file that is not a valid result (``{}``, a
truncated write, another episode's record) is moved to ``episodes/corrupt/`` on resume and its
episode runs again. Each local worker runs one episode at a time and watches the main process: it
exits when the main process dies, even by SIGKILL, and ignores SIGINT (a Ctrl-C reaches the whole
process group), since the main process ends its workers itself when it stops (on SIGINT, on SIGTERM
or on an error). A worker that dies during an episode (killed, out of memory, a crash in native
code) is replaced and its episode run once more; if that attempt dies too, the episode is recorded
with status ``failed`` and the error, and the campaign goes on. Ray retries a task once itself.

One campaign is one version of the code, the models and the configurations: the campaign takes a
digest of them when it starts (:mod:`excavsim.studies.campaign.inputs`; a worker imports the package
once but reads the models and configurations again for every episode), every worker checks it before
and after each episode, and a change stops the campaign with an error naming the files (a merge in the
working tree mid-campaign once made heavy clay's tuned and untuned runs differ from their first pass).
Each result records the digest (``inputs``); on resume a result made with other inputs is moved to
``episodes/stale/`` and its episode runs again.
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
import signal
import socket
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterator
from multiprocessing.connection import wait
from typing import Any

import yaml

from excavsim.handoff.episode import EpisodeObserver, ObserverGroup
from excavsim.errors import ConfigError, DependencyError, ExcavsimError, UsageError
from excavsim.processes import exit_with_parent
from excavsim.studies.campaign import inputs
from excavsim.studies.campaign.grid import (CampaignEpisode, CampaignSpec, check_campaign, episode_id,
                                         expand_grid, load_campaign, parse_campaign)
from excavsim.studies.campaign.report import (format_table, group_table, plot_campaign, summary_rows, write_atomic,
                                           write_tables)
from excavsim.loop.catalog import progress_text
from excavsim.loop.scenario import EpisodeSpec, dig_rows, episode_summary, run_spec

__all__ = ["CampaignEpisode", "CampaignReport", "CampaignSpec", "check_campaign", "episode_id",
           "expand_grid", "load_campaign", "parse_campaign", "result_problem", "run_campaign", "run_episode_task"]


STATUSES = ("ok", "error", "failed")  # an episode ran; it raised; its worker process died twice
ATTEMPTS = 2  # runs of an episode whose worker process dies, before it is recorded as failed


@dataclasses.dataclass
class CampaignReport:
    """What :func:`run_campaign` did: the episodes, how many ran now, and one summary row per episode."""

    out_dir: pathlib.Path
    episodes: list[CampaignEpisode]
    ran: int
    rows: list[dict[str, Any]]
    plots: list[pathlib.Path]

    @property
    def errors(self) -> int:
        """Episodes whose status is not ``ok`` (``error``: the episode raised; ``failed``: its worker died)."""
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


# An extra observer of every episode, made in the worker from the episode's result path (picklable: it
# travels to the worker processes), e.g. a logger of one's own.
ObserverFactory = Callable[[pathlib.Path], EpisodeObserver]


def _task(ep: CampaignEpisode, out_dir: pathlib.Path, record: bool, files: dict[str, str] | None = None,
          live: str | None = None, observer: ObserverFactory | None = None) -> dict[str, Any]:
    return {"id": ep.id, "name": ep.name, "params": ep.params, "spec": ep.spec.model_dump(mode="json"),
            "out_dir": str(out_dir.resolve()), "recording": f"recordings/{ep.id}.rrd" if record else None,
            "live": live, "observer": observer, "inputs": files}


class InputsChanged(ExcavsimError):
    """The files a campaign's episodes read changed while it ran (:mod:`excavsim.studies.campaign.inputs`)."""


def run_episode_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one campaign episode (in a worker) and return its result record; never raises.

    Args:
        task: ``id``, ``name``, ``params``, ``spec`` (an EpisodeSpec as JSON), ``out_dir``,
            ``recording`` (a path under ``out_dir``, or None: the episode's task records it there with its
            own recorder), ``live`` (a viewer's address the recording also streams to, or None) and
            ``observer`` (a factory of an extra observer, called with the episode's result path, or None) and
            ``inputs`` (the campaign's
            :func:`~excavsim.studies.campaign.inputs.digest` when it started, or None: not checked).

    Returns:
        A JSON-ready record: the task's fields, ``status`` (``ok`` or ``error``), ``summary`` (see
        :func:`~excavsim.loop.scenario.episode_summary`), ``digs`` (one row per dig,
        :func:`~excavsim.loop.scenario.dig_rows`), ``error`` and ``traceback`` when the
        episode raised, the episode's ``log`` lines, ``wall_s``, ``host``, ``pid``, ``inputs`` (the
        inputs' :func:`~excavsim.studies.campaign.inputs.combined` digest when checked) and, when the
        inputs differ from ``task["inputs"]`` before or after the episode, ``inputs_changed`` (the files;
        status ``error``; the episode does not run when they differ before it).
    """
    log: list[str] = []
    rec = {k: task[k] for k in ("id", "name", "params", "spec", "recording")}
    rec.update(status="ok", summary=None, error=None, traceback=None, log=log, host=socket.gethostname(),
               pid=os.getpid())
    t0 = time.perf_counter()
    expected = task.get("inputs")
    if expected is not None:
        rec["inputs"] = inputs.combined(expected)
        if moved := inputs.changed(expected, inputs.digest()):
            return _json_safe(_inputs_changed(rec, moved, "before", t0))
    try:
        spec = EpisodeSpec.model_validate(task["spec"])
        observer = None
        if task["recording"]:  # the task's own recorder (a task that streams also streams to the viewer)
            path = pathlib.Path(task["out_dir"]) / task["recording"]
            path.parent.mkdir(parents=True, exist_ok=True)
            live = task.get("live") if "live" in spec.plugin.outputs else None
            observer = spec.plugin.recorder(str(path), live=live)
        if task.get("observer") is not None:
            extra = task["observer"](pathlib.Path(task["out_dir"]) / "episodes" / f"{task['id']}.json")
            observer = ObserverGroup(observer, extra)
        result = run_spec(spec, progress=log.append, observer=observer)
        rec["summary"], rec["digs"] = episode_summary(result, spec.task), dig_rows(result, spec.task)
    except Exception as exc:  # noqa: BLE001 - a failing episode is a result, not the campaign's end
        rec.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
    if expected is not None and (moved := inputs.changed(expected, inputs.digest())):
        return _json_safe(_inputs_changed(rec, moved, "during", t0))
    rec["wall_s"] = time.perf_counter() - t0
    return _json_safe(rec)


def _inputs_changed(rec: dict[str, Any], files: list[str], when: str, t0: float) -> dict[str, Any]:
    rec.update(status="error", summary=None, inputs_changed=files, inputs_changed_when=when,
               wall_s=time.perf_counter() - t0,
               error=f"InputsChanged: {len(files)} file(s) the episodes read changed since the campaign started "
                     f"({inputs.describe(files)}), {when} this episode")
    return rec


def _failed_record(task: dict[str, Any], error: str) -> dict[str, Any]:
    """The result record of an episode that produced none: status ``failed`` with ``error``."""
    return _json_safe({**{k: task[k] for k in ("id", "name", "params", "spec", "recording")},
                       "status": "failed", "summary": None, "error": error, "traceback": None, "log": [],
                       "wall_s": None})


# -- local worker processes ----------------------------------------------------------------------------
def threads_per_worker(workers: int, tasks: int, cores: int | None = None) -> int:
    """numba threads for each of ``workers`` local workers running ``tasks`` episodes: the cores this
    process may use (its affinity, so ``taskset`` counts) shared out among the workers that will run."""
    if cores is None:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, cores // max(1, min(workers, tasks)))


def _worker_main(conn, threads: int = 0) -> None:
    """A local worker: run the episodes the main process sends, one at a time, until it sends None.

    ``threads`` (> 0) caps numba's threads (the ray caster runs in parallel): workers that together
    fill the machine would otherwise each start a thread per core and fight over them.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the main process decides; it ends its workers itself
    exit_with_parent()
    if threads > 0:
        import numba

        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):  # the main process closed its end
            return
        if task is None:
            return
        conn.send(run_episode_task(task))


class _Worker:
    """One local worker process and the episode it runs (None: idle)."""

    def __init__(self, ctx, threads: int = 0):
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child, threads), daemon=True,
                                name="excavsim-campaign-worker")
        self.proc.start()
        child.close()
        self.task: dict[str, Any] | None = None
        self.attempt = 0

    def run(self, task: dict[str, Any], attempt: int) -> None:
        """Send ``task`` (its ``attempt``-th run); a process that died meanwhile is found by its sentinel."""
        self.task, self.attempt = task, attempt
        with contextlib.suppress(OSError):
            self.conn.send(task)

    def stop(self, *, grace_s: float = 5.0) -> None:
        """End the process: ask an idle one to quit, terminate a busy one, kill it if it lingers."""
        if self.proc.is_alive() and self.task is None:
            with contextlib.suppress(OSError):
                self.conn.send(None)
            self.proc.join(grace_s)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(grace_s)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


def _death(proc) -> str:
    """How a worker process ended, in words (its exit code or the signal that killed it)."""
    code = proc.exitcode
    if code is not None and code < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-code).name}"
    return f"exit code {code}"


# -- backends: each yields result records as episodes finish -------------------------------------------
def _local_results(tasks: list[dict], workers: int, say: Callable[[str], None]) -> Iterator[dict]:
    """Run ``tasks`` on ``workers`` local processes (see the module docstring for what a death does)."""
    # MuJoCo and numba are not fork-safe: workers start from a clean interpreter.
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    ctx = multiprocessing.get_context(method)
    todo = deque((t, 1) for t in tasks)
    pool: list[_Worker] = []
    threads = threads_per_worker(workers, len(tasks))
    try:
        while todo or any(w.task is not None for w in pool):
            for w in [w for w in pool if w.task is None and not w.proc.is_alive()]:  # died while idle
                w.stop()
                pool.remove(w)
            for w in pool:
                if todo and w.task is None:
                    w.run(*todo.popleft())
            while todo and len(pool) < workers:
                pool.append(_Worker(ctx, threads))
                pool[-1].run(*todo.popleft())
            busy = [w for w in pool if w.task is not None]
            ready = set(wait([w.conn for w in busy] + [w.proc.sentinel for w in busy]))
            for w in busy:
                rec = None
                if w.conn in ready:
                    with contextlib.suppress(EOFError, OSError):
                        rec = w.conn.recv()
                if rec is not None:
                    w.task = None
                    yield rec
                elif w.conn in ready or w.proc.sentinel in ready:  # it died before sending a result
                    task, attempt = w.task, w.attempt
                    w.proc.join()
                    how = f"the worker process {w.proc.pid} running it died ({_death(w.proc)})"
                    w.task = None
                    w.stop()
                    pool.remove(w)
                    if attempt < ATTEMPTS:
                        say(f"{task['id']}: {how}; running it again")
                        todo.appendleft((task, attempt + 1))
                    else:
                        yield _failed_record(task, f"{how} on each of {ATTEMPTS} attempts (killed, out of memory "
                                                   "or crashed in native code?)")
    finally:
        for w in pool:
            w.stop()


def _import_ray():
    try:
        import ray
    except ImportError:
        ray = None
    if not hasattr(ray, "remote"):  # missing, or a bare ``ray/`` folder (Ray's /tmp/ray) seen as a namespace
        raise DependencyError("running a campaign on Ray needs Ray, an optional extra: pip install 'excavsim[ray]' "
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
            raise DependencyError(f"cannot start or reach Ray at {address!r}: {exc}; give 'local' for a "
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
                    yield _failed_record(task, f"Ray: {exc}")
    finally:
        for ref in pending:
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)
        if started:
            ray.shutdown()


# -- files ---------------------------------------------------------------------------------------------
def result_problem(path: pathlib.Path, episode: str) -> str | None:
    """Why ``path`` is not a valid result file of episode ``episode``, or None when it is one: it must be
    a JSON object with that ``id``, a ``status`` of :data:`STATUSES`, and a ``summary`` with ``end`` and
    ``digs`` (status ok) or an ``error`` text (otherwise)."""
    try:
        rec = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return f"unreadable: {type(exc).__name__}: {str(exc)[:120]}"
    if not isinstance(rec, dict):
        return f"a JSON {type(rec).__name__}, not an object"
    if rec.get("id") != episode:
        return f"its id is {str(rec.get('id'))[:80]!r}, not {episode!r}"
    status = rec.get("status")
    if status not in STATUSES:
        return f"status {str(status)[:80]!r} (allowed: {', '.join(STATUSES)})"
    if status == "ok":
        summary = rec.get("summary")
        if not (isinstance(summary, dict) and "end" in summary and "digs" in summary):
            return "status ok without a summary holding end and digs"
    elif not isinstance(rec.get("error"), str):
        return f"status {status} without an error text"
    return None


def _move_aside(path: pathlib.Path, folder: pathlib.Path) -> pathlib.Path:
    """Move ``path`` into ``folder`` (created) without replacing an earlier file there; returns where."""
    folder.mkdir(parents=True, exist_ok=True)
    target, n = folder / path.name, 0
    while target.exists():
        n += 1
        target = folder / f"{path.name}.{n}"
    os.replace(path, target)
    return target


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """While inside, SIGTERM raises KeyboardInterrupt as SIGINT does, so that a terminated campaign ends
    its workers and says what is saved (only in the main thread, where signal handlers can be set)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(_signum, _frame):
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


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
            raise UsageError(f"{out} is in use by another campaign run; wait for it to end or choose "
                             "another --out directory") from None
        yield


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600} h {s % 3600 // 60:02d} min" if s >= 3600 else f"{s // 60} min {s % 60:02d} s"


def _progress_line(count: int, total: int, rec: dict, eta_s: float) -> str:
    head = f"[{count}/{total}] {rec['id']}:"
    if rec["status"] != "ok":
        text = f"{head} {str(rec['status']).upper()} {str(rec['error']).splitlines()[0][:200]}"
    else:
        s = rec["summary"]
        task = s.get("task") or rec["spec"]["task"]
        text = f"{head} {s['end']}: {progress_text(s, task)} ({rec['wall_s']:.0f} s)"
    return f"{text}; ETA {_duration(eta_s)}" if count < total else text


# -- the campaign --------------------------------------------------------------------------------------
def _set_aside_stale(ep_dir: pathlib.Path, ids: set[str], current: str, say: Callable[[str], None],
                     done: set[str]) -> None:
    """Move the results among ``ids`` made with other inputs than ``current`` (their ``inputs`` digest) to
    ``episodes/stale/`` and drop them from ``done``, so that their episodes run again; results without a
    digest (made before campaigns recorded one) stay, with a note."""
    stale, unknown = [], 0
    for ep_id in sorted(ids):
        path = ep_dir / f"{ep_id}.json"
        try:
            made_with = json.loads(path.read_text(encoding="utf-8")).get("inputs")
        except (OSError, ValueError):
            continue  # result_problem has moved an unreadable one aside already
        if made_with is None:
            unknown += 1
        elif made_with != current:
            _move_aside(path, ep_dir / "stale")
            done.discard(ep_id)
            stale.append(ep_id)
    if stale:
        say(f"note: {len(stale)} result(s) were made with other code, models or configurations than these "
            f"(inputs {current}); moved to {ep_dir / 'stale'}, their episodes run again")
    if unknown:
        say(f"note: {unknown} result(s) carry no inputs digest (made before campaigns recorded one): kept, but "
            "nothing shows they were made with this code, these models and configurations")


def run_campaign(spec: CampaignSpec, out_dir: str | pathlib.Path, *, workers: int | None = None,
                 resume: bool = False, ray_address: str | None = None, live: tuple[str, str] | None = None,
                 observer: ObserverFactory | None = None,
                 progress: Callable[[str], None] | None = print) -> CampaignReport:
    """Run the campaign's episodes in parallel, then write its summary table and plots.

    Args:
        spec: the campaign.
        out_dir: where results go (created; see the module docstring for the layout).
        workers: local processes (default ``os.cpu_count()``); with Ray on this machine, its CPUs.
        resume: run only the episodes without a valid result file in ``out_dir`` (an invalid one is
            moved to ``episodes/corrupt/``); without it an ``out_dir`` that holds results is refused.
        ray_address: None for local processes; ``"local"`` for a Ray instance started here,
            ``"auto"`` or ``HOST:PORT`` for a running Ray cluster (needs a shared ``out_dir`` only
            when recording).
        live: (viewer address, episode id): with ``record: true``, that episode's recording also streams to the
            viewer (when its task's recorder streams). Each episode is recorded by its own task's recorder
            (:meth:`~excavsim.loop.plugin.TaskPlugin.recorder`).
        observer: an extra observer of every episode: called in the worker with the episode's result path, it
            returns the observer; it must be picklable (a class or a module-level function).
        progress: receives one line per finished episode (count, result, ETA) and the summary.

    Raises:
        ConfigError: the grid is invalid.
        ExcavsimError: ``out_dir`` holds results and ``resume`` is false, it is in use by another run,
            ``workers`` is below 1, Ray is missing or unreachable, or ``record: true`` over a task that has
            no recorder. A worker process that dies does not raise (see the module docstring).
        KeyboardInterrupt: on SIGINT or SIGTERM, after the local workers are ended.
    """
    say = progress or (lambda _s: None)
    if workers is not None and workers < 1:
        raise ConfigError(f"workers must be at least 1; given {workers}")
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
            raise UsageError(f"{out} already holds {len(done)} episode result(s); run with --resume to run "
                             "only the missing episodes, or choose another --out directory")
        ids = {e.id for e in episodes}
        if stale := done - ids:
            say(f"note: {len(stale)} result file(s) in {ep_dir} are not episodes of this campaign "
                "(an earlier grid?); the summary leaves them out")
        for ep_id in sorted(done & ids):
            path = ep_dir / f"{ep_id}.json"
            if problem := result_problem(path, ep_id):
                moved = _move_aside(path, ep_dir / "corrupt")
                say(f"note: {path} is not a valid result ({problem}); moved to {moved}, its episode runs again")
                done.discard(ep_id)
        files = inputs.digest()
        _set_aside_stale(ep_dir, done & ids, inputs.combined(files), say, done)
        todo = [e for e in episodes if e.id not in done]
        write_atomic(out / "campaign.yaml", yaml.safe_dump(spec.model_dump(mode="json"), sort_keys=False))

        n = min(workers or os.cpu_count() or 1, max(len(todo), 1))
        where = f"Ray ({ray_address})" if ray_address else f"{n} local process{'es' if n > 1 else ''}"
        say(f"campaign {spec.name}: {len(episodes)} episodes, {len(episodes) - len(todo)} already done, "
            f"{len(todo)} to run on {where}; results in {out}")
        if spec.record and (silent := sorted({e.spec.task for e in todo if not e.spec.plugin.can_record})):
            raise UsageError(f"campaign {spec.name} has record: true, and task {', '.join(silent)} has no recorder; "
                             "leave record out, or run the other tasks")
        tasks = [_task(e, out, spec.record, files, live[0] if live and e.id == live[1] else None, observer)
                 for e in todo]
        results = _ray_results(tasks, ray_address, workers) if ray_address else _local_results(tasks, n, say)
        count, ran, t0 = len(episodes) - len(todo), 0, time.perf_counter()
        try:
            with _sigterm_interrupts():
                for rec in results if tasks else ():
                    if files_changed := rec.get("inputs_changed"):
                        raise InputsChanged(
                            f"campaign {spec.name} stopped: {len(files_changed)} file(s) its episodes read changed "
                            f"while it ran ({inputs.describe(files_changed)}; seen {rec['inputs_changed_when']} "
                            f"episode {rec['id']}); the {count} result(s) in {ep_dir} were made with the files as "
                            "they were when it started. Once the change is done, run it again with --resume: "
                            "results made with other inputs are moved to episodes/stale/ and run again")
                    write_atomic(ep_dir / f"{rec['id']}.json", json.dumps(rec, indent=1, allow_nan=False) + "\n")
                    count, ran = count + 1, ran + 1
                    eta = (time.perf_counter() - t0) / ran * (len(todo) - ran)
                    say(_progress_line(count, len(episodes), rec, eta))
        except KeyboardInterrupt:
            say(f"interrupted: {count} of {len(episodes)} results saved in {ep_dir}; its workers are ended; "
                "run again with --resume")
            raise
        finally:
            results.close()  # ends the local workers (a generator that never started has none)
        rows = summary_rows(episodes, ep_dir)
        tables = write_tables(rows, out, progress=say)
        plots = plot_campaign(spec, rows, out / "plots")
        say(format_table(spec, rows))
        for keys in spec.report_by:
            say(f"\nby {', '.join(keys)}:\n" + group_table(rows, keys, ep_dir))
        say("wrote " + ", ".join(str(p) for p in [*tables, *plots]))
    return CampaignReport(out, episodes, ran, rows, plots)
