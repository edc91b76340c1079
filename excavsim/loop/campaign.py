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
import csv
import dataclasses
import hashlib
import io
import itertools
import json
import math
import multiprocessing
import numbers
import os
import pathlib
import re
import socket
import tempfile
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
from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec, episode_summary, merge, resolve_goal, run_spec

OVERRIDE_SECTIONS = ("robot", "scene", "planner", "executor", "sensing")
ENDS = ("done", "no_dig", "budget", "error")  # how an episode ended, in the order plots stack them
_END_COLOURS = {"done": "#2ca02c", "no_dig": "#7f7f7f", "budget": "#ff7f0e", "error": "#d62728"}


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


def _slug(value: Any) -> str:
    text = value if isinstance(value, str) else json.dumps(value, sort_keys=True)
    return re.sub(r"[^A-Za-z0-9_.]+", "_", text).strip("_.")


def episode_id(spec: EpisodeSpec, params: dict[str, Any]) -> str:
    """A stable, file-name-safe id: the grid values (numbers after their key), then a hash of the spec.

    The hash covers the canonical JSON of ``spec`` without its name and without fields left at their
    defaults (so a new EpisodeSpec field does not change the ids of older campaigns).
    """
    canonical = json.dumps(spec.model_dump(mode="json", exclude={"name"}, exclude_defaults=True),
                           sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:10]
    parts = [v if isinstance(v, str) else f"{k.rsplit('.', 1)[-1]}{json.dumps(v)}" for k, v in params.items()]
    slug = "-".join(_slug(p) for p in parts) if params else _slug(spec.name)
    slug = slug[:60].strip("-_.")
    return f"{slug}-{digest}" if slug else digest


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
        name = " ".join(f"{k}={_slug(v)}" for k, v in params.items()) or spec.base.name
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
def _write_atomic(path: pathlib.Path, text: str) -> None:
    """Write ``text`` to ``path`` through a synced temporary file in the same directory and a rename."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            os.fchmod(f.fileno(), 0o644)  # mkstemp's 0600 would hide results from other users
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    with contextlib.suppress(OSError):  # make the rename itself durable
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


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
        _write_atomic(out / "campaign.yaml", yaml.safe_dump(spec.model_dump(mode="json"), sort_keys=False))

        n = min(workers or os.cpu_count() or 1, max(len(todo), 1))
        where = f"Ray ({ray_address})" if ray_address else f"{n} local process{'es' if n > 1 else ''}"
        say(f"campaign {spec.name}: {len(episodes)} episodes, {len(episodes) - len(todo)} already done, "
            f"{len(todo)} to run on {where}; results in {out}")
        tasks = [_task(e, out, spec.record) for e in todo]
        results = _ray_results(tasks, ray_address, workers) if ray_address else _local_results(tasks, n)
        count, ran, t0 = len(episodes) - len(todo), 0, time.perf_counter()
        try:
            for rec in results if tasks else ():
                _write_atomic(ep_dir / f"{rec['id']}.json", json.dumps(rec, indent=1, allow_nan=False) + "\n")
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


# -- summary -------------------------------------------------------------------------------------------
def _cell(value: Any) -> Any:
    return value if value is None or isinstance(value, (str, int, float)) else json.dumps(value, sort_keys=True)


def summary_rows(episodes: list[Episode], ep_dir: pathlib.Path) -> list[dict[str, Any]]:
    """One flat row per episode, in grid order: id, name, the grid values, status, the summary numbers."""
    rows = []
    for ep in episodes:
        row: dict[str, Any] = {"id": ep.id, "name": ep.name, **{k: _cell(v) for k, v in ep.params.items()}}
        path = ep_dir / f"{ep.id}.json"
        try:
            rec = json.loads(path.read_text())
        except FileNotFoundError:
            rec = {"status": "missing", "error": "no result file"}
        except (OSError, json.JSONDecodeError) as exc:
            rec = {"status": "error", "error": f"unreadable result file {path}: {exc}"}
        row["status"] = rec["status"]
        for key, value in (rec.get("summary") or {}).items():
            if not isinstance(value, list):
                row[key] = value
        row["error"] = (rec.get("error") or "").splitlines()[0] if rec.get("error") else ""
        rows.append(row)
    return rows


def write_tables(rows: list[dict[str, Any]], out: pathlib.Path, *,
                 progress: Callable[[str], None] | None = None) -> list[pathlib.Path]:
    """Write ``summary.csv`` and, when pyarrow is importable, ``summary.parquet``; returns the paths."""
    columns = list(dict.fromkeys(k for row in rows for k in row))
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    paths = [out / "summary.csv"]
    _write_atomic(paths[0], buf.getvalue())
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return paths
    try:
        table = pa.Table.from_pylist([{c: row.get(c) for c in columns} for row in rows])
        tmp = out / ".summary.parquet.tmp"
        pq.write_table(table, tmp)
        os.replace(tmp, out / "summary.parquet")
        paths.append(out / "summary.parquet")
    except (pa.ArrowException, OSError) as exc:  # e.g. a grid column mixing types
        if progress:
            progress(f"note: summary.parquet not written ({exc}); summary.csv has every row")
    return paths


def _group_keys(spec: CampaignSpec) -> list[str]:
    """The grid keys that define conditions: those with several values, seeds being replicates."""
    varied = [k for k, v in spec.grid.items() if len(v) > 1]
    return [k for k in varied if k != "seed"] or varied


def _label(row: dict, keys: list[str]) -> str:
    return ", ".join(f"{k.rsplit('.', 1)[-1]}={row[k]}" for k in keys) or "all"


def _outcome(row: dict) -> str:
    return row.get("end", "error") if row["status"] == "ok" else "error"


def format_table(spec: CampaignSpec, rows: list[dict[str, Any]]) -> str:
    """A compact text table: one line per condition (grid values other than seed), means over its episodes."""
    keys = [k for k in spec.grid if k != "seed"]
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault(tuple(row[k] for k in keys), []).append(row)

    def mean(rs: list[dict], key: str, scale: float = 1.0) -> str:
        vals = [r[key] for r in rs if r["status"] == "ok" and r.get(key) is not None]
        return f"{scale * sum(vals) / len(vals):.1f}" if vals else "-"

    header = [k.rsplit(".", 1)[-1] for k in keys] + ["episodes", "errors", "done", "l/dig", "digs", "removed %"]
    lines = []
    for values, rs in groups.items():
        lines.append([str(v) for v in values] + [str(len(rs)), str(sum(r["status"] != "ok" for r in rs)),
                                                 str(sum(_outcome(r) == "done" for r in rs)),
                                                 mean(rs, "dug_l_per_dig"), mean(rs, "digs"),
                                                 mean(rs, "removed_fraction", 100.0)])
    widths = [max(len(c) for c in col) for col in zip(header, *lines)]
    fmt = "  ".join(f"{{:<{w}}}" if i < len(keys) else f"{{:>{w}}}" for i, w in enumerate(widths))
    return "\n".join(fmt.format(*line) for line in [header, *lines])


def plot_campaign(spec: CampaignSpec, rows: list[dict[str, Any]], plot_dir: pathlib.Path) -> list[pathlib.Path]:
    """Draw soil per dig, digs, removed fraction and how episodes ended, grouped by grid parameter.

    One figure ``by_<key>.png`` per varied grid key (seed only when nothing else varies), and
    ``conditions.png`` over the combinations when two or more keys vary; ``episodes.png`` when
    nothing varies. Returns the paths.
    """
    keys = _group_keys(spec)
    done_at = None if "done_fraction" in spec.grid else spec.base.done_fraction
    figures = [(f"by_{_slug(k)}.png", [_label(r, [k]) for r in rows], k) for k in keys]
    if len(keys) > 1:
        figures.append(("conditions.png", [_label(r, keys) for r in rows], " x ".join(keys)))
    if not keys:
        figures.append(("episodes.png", [r["id"] for r in rows], "episode"))
    return [_plot_groups(rows, labels, title, plot_dir / fname, done_at=done_at)
            for fname, labels, title in figures]


def _plot_groups(rows: list[dict], labels: list[str], title: str, path: pathlib.Path, *,
                 done_at: float | None) -> pathlib.Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    groups = list(dict.fromkeys(labels))
    xs = [groups.index(lab) for lab in labels]
    fig = Figure(figsize=(4.0 + 3.2 * 4 + 0.25 * len(groups), 4.2), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 4)
    panels = (("dug_l_per_dig", 1.0, "soil in the bucket per dig [l]"),
              ("digs", 1.0, "digs (to finish, when done)"),
              ("removed_fraction", 100.0, "goal volume removed [%]"))
    for ax, (key, scale, ylabel) in zip(axes, panels):
        for g in range(len(groups)):
            pts = [(r, scale * r[key]) for r, x in zip(rows, xs)
                   if x == g and r["status"] == "ok" and r.get(key) is not None]
            if not pts:
                continue
            offsets = [0.0] if len(pts) == 1 else [-0.2 + 0.4 * i / (len(pts) - 1) for i in range(len(pts))]
            ax.scatter([g + o for o in offsets], [y for _, y in pts], s=22, zorder=3,
                       c=[_END_COLOURS[_outcome(r)] for r, _ in pts])
            ax.hlines(sum(y for _, y in pts) / len(pts), g - 0.3, g + 0.3, colors="k", lw=1.5, zorder=4)
        if key == "removed_fraction" and done_at is not None:
            ax.axhline(100 * done_at, color=_END_COLOURS["done"], ls="--", lw=1)
        ax.set_ylim(bottom=0, top=105 if key == "removed_fraction" else None)
        ax.set_ylabel(ylabel)
    ax = axes[3]
    bottom = [0] * len(groups)
    for end in ENDS:
        counts = [sum(1 for r, x in zip(rows, xs) if x == g and _outcome(r) == end) for g in range(len(groups))]
        ax.bar(range(len(groups)), counts, bottom=bottom, color=_END_COLOURS[end], width=0.6)
        bottom = [b + c for b, c in zip(bottom, counts)]
    ax.set_ylabel("episodes by how they ended")
    ax.legend(handles=[Patch(color=_END_COLOURS[e], label=e) for e in ENDS], fontsize=8, loc="upper left",
              bbox_to_anchor=(1.02, 1.0), title="ended", title_fontsize=8)
    for ax in axes[1], axes[3]:
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in axes:
        ax.set_xticks(range(len(groups)), groups, rotation=30 if len(groups) > 3 else 0, ha="right"
                      if len(groups) > 3 else "center", fontsize=8)
        ax.set_xlim(-0.6, len(groups) - 0.4)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"by {title} (points: episodes, coloured by how they ended; black lines: means)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    fig.savefig(tmp, format="png", bbox_inches="tight")
    os.replace(tmp, path)
    return path
