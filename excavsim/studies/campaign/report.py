"""Campaign summaries: the table of episodes (CSV, Parquet), the printed table, and the plots."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import pathlib
import tempfile
from collections.abc import Callable
from typing import Any

from excavsim.config import load_planner_config
from excavsim.loop import catalog
from excavsim.studies.campaign.grid import CampaignEpisode, CampaignSpec, slug

# how an episode ended, in the order plots stack them ("error": it raised, or its worker died)
ENDS = ("done", "no_dig", "budget", "diverged", "timeout", "error")
_END_COLOURS = {"done": "#2ca02c", "no_dig": "#7f7f7f", "budget": "#ff7f0e", "diverged": "#9467bd",
                "timeout": "#8c564b", "error": "#d62728"}


def write_atomic(path: pathlib.Path, text: str) -> None:
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


def _cell(value: Any) -> Any:
    return value if value is None or isinstance(value, (str, int, float)) else json.dumps(value, sort_keys=True)


def summary_rows(episodes: list[CampaignEpisode], ep_dir: pathlib.Path) -> list[dict[str, Any]]:
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
        if "task" in ep.params:  # a campaign over tasks: the task by name (not its grid mapping) and its machine
            row["task"], row["machine"] = ep.spec.task, ep.spec.machine_name
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
    write_atomic(paths[0], buf.getvalue())
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


def task_columns() -> list[tuple[str, str]]:
    """The tasks' own columns of the table (each plug-in's ``columns``, in the catalog's order, each key once):
    shown when some episode has the metric."""
    out: dict[str, str] = {}
    for plugin in catalog.plugins().values():
        for key, label in plugin.columns:
            out.setdefault(key, label)
    return list(out.items())


def format_table(spec: CampaignSpec, rows: list[dict[str, Any]]) -> str:
    """A compact text table: one line per condition (grid values other than seed), means over its episodes.

    A campaign over tasks has a task and a machine column; the columns of one task's metrics
    (:func:`task_columns`) appear when some episode has them, with "-" where they do not apply."""
    keys = [k for k in spec.grid if k != "seed"]
    if "task" in keys:
        keys.insert(keys.index("task") + 1, "machine")
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault(tuple(row[k] for k in keys), []).append(row)
    extra = [(key, label) for key, label in task_columns() if any(r.get(key) is not None for r in rows)]

    def mean(rs: list[dict], key: str, scale: float = 1.0) -> str:
        vals = [r[key] for r in rs if r["status"] == "ok" and r.get(key) is not None]
        return f"{scale * sum(vals) / len(vals):.1f}" if vals else "-"

    header = [k.rsplit(".", 1)[-1] for k in keys] + ["episodes", "errors", "done", "l/dig", "digs", "stalls",
                                                      "removed %"] + [label for _, label in extra]
    lines = []
    for values, rs in groups.items():
        lines.append([str(v) for v in values] + [str(len(rs)), str(sum(r["status"] != "ok" for r in rs)),
                                                 str(sum(_outcome(r) == "done" for r in rs)),
                                                 mean(rs, "dug_l_per_dig"), mean(rs, "digs"), mean(rs, "stalls"),
                                                 mean(rs, "removed_fraction", 100.0)]
                     + [mean(rs, key) for key, _ in extra])
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
    done_at = None if "done_fraction" in spec.grid else getattr(spec.base.options, "done_fraction", None)
    figures = [(f"by_{slug(k)}.png", [_label(r, [k]) for r in rows], k) for k in keys]
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


def repeated_failures(digs: list[dict[str, Any]], steps: tuple[float, float, float]) -> int:
    """How many planned digs of an episode (its per-dig rows, :func:`~excavsim.loop.scenario.dig_rows`)
    repeat an earlier failed one: their action within one grid cell (``steps``: k [m], alpha [deg],
    d1 [m]) of a dig that failed. The loop's memory allows that only where the terrain changed since
    (soil moved there), which the rows do not tell: this is an upper bound on blind repeats."""
    failed: list[tuple[float, float, float]] = []
    count = 0
    for d in digs:
        a = (d.get("k_m"), d.get("alpha_deg"), d.get("d1_m"))
        if any(v is None or v != v for v in a):  # a fallback dig (no action)
            continue
        if any(all(abs(x - y) <= s * (1 + 1e-6) for x, y, s in zip(a, f, steps)) for f in failed):
            count += 1
        if d.get("failure"):
            failed.append(a)
    return count


def _grid_steps(rec: dict[str, Any]) -> tuple[float, float, float]:
    grid = load_planner_config().grid.model_dump()
    grid.update(((rec.get("spec") or {}).get("planner") or {}).get("grid") or {})
    return float(grid["k_step_m"]), float(grid["alpha_step_deg"]), float(grid["d1_step_m"])


def group_table(rows: list[dict[str, Any]], keys: list[str], ep_dir: pathlib.Path) -> str:
    """The episodes grouped by the grid values of ``keys`` (seeds and every other key pooled): per
    group, episodes, done, stalls per episode, litres per dig, digs of the episodes that ended done,
    the share of failed digs (stall, no contact, timeout or under 1 l), and the digs that repeat an
    earlier failed action (:func:`repeated_failures`; counted from the episodes' per-dig rows). A task
    without stalls or failed digs (a truck trial) counts none."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        if row["status"] == "ok":
            groups.setdefault(tuple(row.get(k) for k in keys), []).append(row)
    header = [k.rsplit(".", 1)[-1] for k in keys] + ["episodes", "done", "stalls/ep", "l/dig", "digs to done",
                                                    "failed %", "repeats"]
    lines = []
    for values, rs in sorted(groups.items(), key=lambda kv: tuple(str(v) for v in kv[0])):
        digs = sum(r["digs"] for r in rs)
        done = [r for r in rs if r.get("end") == "done"]
        repeats, known = 0, 0
        for r in rs:
            try:
                rec = json.loads((ep_dir / f"{r['id']}.json").read_text())
            except (OSError, json.JSONDecodeError):
                continue
            if "digs" in rec:
                known += 1
                repeats += repeated_failures(rec["digs"], _grid_steps(rec))
        lines.append([str(v) for v in values] + [
            str(len(rs)), f"{len(done)}/{len(rs)}", f"{sum(r.get('stalls', 0) for r in rs) / len(rs):.2f}",
            f"{sum(r.get('dug_l_per_dig', 0.0) * r['digs'] for r in rs) / max(digs, 1):.1f}",
            f"{sum(r['digs'] for r in done) / len(done):.1f}" if done else "-",
            f"{100 * sum(r.get('failed_digs', 0) for r in rs) / max(digs, 1):.1f}",
            f"{repeats}" + ("" if known == len(rs) else f" ({known} of {len(rs)} ep.)")])
    widths = [max(len(c) for c in col) for col in zip(header, *lines)]
    fmt = "  ".join(f"{{:<{w}}}" if i < len(keys) else f"{{:>{w}}}" for i, w in enumerate(widths))
    return "\n".join(fmt.format(*line) for line in [header, *lines])
