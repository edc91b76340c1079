"""The planner regression suite: golden scenarios, a committed baseline, and a verdict.

Every ``configs/regress/*.yaml`` is an :class:`~excavsim.loop.scenario.EpisodeSpec` (a golden
scenario: fixed goal, soil, seed and settings). ``excavsim regress`` runs each one and compares the
metrics of :func:`~excavsim.loop.scenario.episode_summary` with ``configs/regress/baseline.json``.
Episodes are deterministic for a fixed seed, so on one machine any change is a real change of
behaviour; across machines and library versions floating-point differences can move a dig, so the
comparison uses tolerances (:data:`METRICS`), and only in the direction that is worse. Timings are
printed but never judged. ``--update`` rewrites the baseline from the current run.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pathlib
import tempfile
from collections.abc import Callable

from excavsim import constants
from excavsim.errors import ExcavsimError
from excavsim.loop.scenario import EpisodeSpec, episode_summary, load_spec, run_spec

REGRESS_DIR = constants.CONFIGS_DIR / "regress"
BASELINE_NAME = "baseline.json"


@dataclasses.dataclass(frozen=True)
class Metric:
    """How one summary metric is judged: ``better`` is "higher" or "lower"; a change worse than
    ``abs_tol`` + ``rel_tol`` x |baseline| is a regression."""

    better: str
    abs_tol: float
    rel_tol: float = 0.0


METRICS: dict[str, Metric] = {
    "removed_fraction": Metric("higher", 0.05),
    "dug_l_per_dig": Metric("higher", 1.0, 0.10),
    "efficiency": Metric("higher", 0.05),
    "digs": Metric("lower", 1.0),
    "stalls": Metric("lower", 0.0),
    "overdig_max_cm": Metric("lower", 1.0),
    "underdig_max_cm": Metric("lower", 1.5),
    "underdig_rms_cm": Metric("lower", 0.5),
    "peak_wrist_pitch_nm": Metric("lower", 0.0, 0.10),
}
INFO = ("end", "planning_s", "wall_s", "sim_s")  # printed, never judged


@dataclasses.dataclass
class Change:
    scenario: str
    metric: str
    baseline: float | str | None
    now: float | str | None
    verdict: str  # "regression", "improved", "changed", "same", "new", "missing"


def scenarios(directory: pathlib.Path = REGRESS_DIR) -> dict[str, EpisodeSpec]:
    """The golden scenarios of ``directory`` by file stem."""
    directory = pathlib.Path(directory)
    files = sorted(directory.glob("*.yaml"))
    if not files:
        raise ExcavsimError(f"no regression scenarios (*.yaml) in {directory}")
    return {f.stem: load_spec(f) for f in files}


def load_baseline(path: pathlib.Path) -> dict:
    """The committed baseline (``{}`` when the file does not exist yet)."""
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ExcavsimError(f"{path}: not valid JSON ({exc}); rewrite it with `excavsim regress --update`") from None


def write_baseline(path: pathlib.Path, results: dict[str, dict]) -> None:
    """Write the baseline atomically (a temporary file renamed over the old one)."""
    # wall-clock times are machine-dependent: printed by a run, never stored in the baseline
    stored = set(METRICS) | {"end", "sim_s"}
    keep = {name: {k: v for k, v in row.items() if k in stored} for name, row in results.items()}
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".baseline-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(keep, fh, indent=2, sort_keys=True)
        fh.write("\n")
    os.replace(tmp, path)


def compare(baseline: dict, results: dict[str, dict], *, partial: bool = False) -> list[Change]:
    """Every judged metric of every scenario against the baseline.

    A baseline scenario without a result is "missing" (its file was removed), unless ``partial``:
    only some scenarios were run (``--only``), and those not run are neither missing nor compared.
    """
    out = []
    for name, row in results.items():
        base = baseline.get(name)
        for metric, rule in METRICS.items():
            now = row.get(metric)
            if base is None or metric not in base:
                out.append(Change(name, metric, None, now, "new"))
                continue
            was = base[metric]
            slack = rule.abs_tol + rule.rel_tol * abs(was)
            worse = (was - now) if rule.better == "higher" else (now - was)
            if worse > slack + 1e-9:
                verdict = "regression"
            elif -worse > slack + 1e-9:
                verdict = "improved"
            elif not math.isclose(now, was, rel_tol=1e-9, abs_tol=1e-9):
                verdict = "changed"
            else:
                verdict = "same"
            out.append(Change(name, metric, was, now, verdict))
        if base is not None:
            for key in INFO:
                if key in base and base[key] != row.get(key) and key == "end":
                    out.append(Change(name, key, base[key], row.get(key), "changed"))
    for name in baseline:
        if name not in results and not partial:
            out.append(Change(name, "-", None, None, "missing"))
    return out


def format_changes(changes: list[Change], *, show_same: bool = False) -> str:
    """A table of the changes (all of them with ``show_same``)."""

    def fmt(v) -> str:
        return "-" if v is None else (f"{v:.3f}" if isinstance(v, float) else str(v))

    rows = [c for c in changes if show_same or c.verdict != "same"]
    if not rows:
        return "every metric of every scenario matches the baseline"
    lines = [f"{'scenario':<24} {'metric':<22} {'baseline':>12} {'now':>12}  verdict"]
    lines += [f"{c.scenario:<24} {c.metric:<22} {fmt(c.baseline):>12} {fmt(c.now):>12}  {c.verdict}" for c in rows]
    return "\n".join(lines)


def run_regress(directory: pathlib.Path = REGRESS_DIR, *, baseline_path: pathlib.Path | None = None,
                update: bool = False, only: list[str] | None = None,
                progress: Callable[[str], None] = print) -> tuple[list[Change], dict[str, dict]]:
    """Run the golden scenarios and compare (or, with ``update``, rewrite the baseline).

    Returns:
        The changes and each scenario's summary.
    """
    directory = pathlib.Path(directory)
    baseline_path = pathlib.Path(baseline_path or directory / BASELINE_NAME)
    specs = scenarios(directory)
    if only:
        unknown = sorted(set(only) - set(specs))
        if unknown:
            raise ExcavsimError(f"unknown scenario(s) {unknown}; available: {sorted(specs)}")
        specs = {k: v for k, v in specs.items() if k in only}
    results = {}
    for i, (name, spec) in enumerate(specs.items(), start=1):
        res = run_spec(spec)
        results[name] = episode_summary(res)
        r = results[name]
        progress(f"[{i}/{len(specs)}] {name}: {r['digs']} digs, {100 * r['removed_fraction']:.0f} % removed, "
                 f"{r['stalls']} stalls, ended {r['end']} ({r['wall_s']:.1f} s wall)")
    baseline = load_baseline(baseline_path)
    changes = compare(baseline, results, partial=bool(only))
    if update:
        merged = {**baseline, **results} if only else results
        write_baseline(baseline_path, merged)
    return changes, results
