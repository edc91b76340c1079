"""The planner regression suite: golden scenarios over several seeds, judged statistically.

Every ``configs/regress/*.yaml`` is an :class:`~excavsim.loop.scenario.EpisodeSpec` (a golden
scenario: goal, soil, settings) with one extra field, ``seeds``: a count (the seeds ``seed``,
``seed + 1``, ...; default :data:`DEFAULT_SEEDS`) or an explicit list. Each scenario runs once per
seed, so each metric of :func:`~excavsim.loop.scenario.episode_summary` judged here (its task's, :func:`task_metrics`)
is a sample of per-seed values. Episodes are deterministic for a seed on one machine, but
floating-point differences between CPUs grow over an episode into different digs, so one episode's
numbers cannot tell a regression from chaos; a sample can.

Two modes (:mod:`excavsim.studies.regress.stats` states the tests):

* **baseline** (:func:`run_regress`): ``configs/regress/baseline.json`` stores, per scenario and
  metric, the mean, spread, quantiles and per-seed values of a committed run; now's sample is
  compared with it unpaired (one-sided Mann-Whitney U beyond the metric's tolerance, and a bootstrap
  interval of the difference of the means), so it stays valid on another machine or other seeds.
  ``--update`` rewrites the baseline.
* **A/B** (:func:`run_against`): the same scenarios and seeds run with the code at a git ref (in a
  temporary worktree, :mod:`excavsim.studies.regress.against`) or with the scenarios of another directory, and
  with the working tree, side by side on this machine; compared paired by seed (one-sided Wilcoxon
  signed-rank beyond the tolerance, and a bootstrap interval of the mean per-seed difference). No
  baseline is needed, and machine differences cancel.

A metric is a regression only when it is worse in its ``better`` direction, significantly and by
more than its practical tolerance. The episode's end and its timings (``planning_s``, ``wall_s``,
``sim_s``) are printed, never judged.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pathlib
import tempfile
from collections import Counter
from collections.abc import Callable
from typing import Any

from pydantic import Field, field_validator

from excavsim import constants
from excavsim.config import load_config, read_text_file
from excavsim.errors import ConfigError, DataFileError, ExcavsimError, UsageError, shorten
from excavsim.studies.regress import stats as rs
from excavsim.loop import catalog
from excavsim.loop.plugin import Metric
from excavsim.loop.scenario import EpisodeSpec, episode_summary, run_spec

REGRESS_DIR = constants.CONFIGS_DIR / "regress"
BASELINE_NAME = "baseline.json"
BASELINE_FORMAT = 2
DEFAULT_SEEDS = 8


def catalog_aliases() -> dict[str, dict[str, str]]:
    """What the tasks and their fields were called before they were renamed (``tasks``: new -> old name;
    ``fields``: new -> old field), so that a revision from before a renaming runs the same scenarios."""
    fields = {new: old for p in catalog.plugins().values() for old, new in p.renamed_fields.items()}
    return {"tasks": {new: old for old, new in catalog.RENAMED.items()}, "fields": fields}


def task_metrics(task: str) -> dict[str, Metric]:
    """The metrics judged for a scenario of ``task``, with their tolerances (its plug-in's ``metrics``)."""
    return dict(catalog.plugin(task).metrics)


TIMINGS = ("planning_s", "wall_s", "sim_s")  # printed, never judged
# per seed the baseline stores the task's metrics, ``end`` and ``sim_s``; wall-clock times are machine-dependent


class GoldenScenario(EpisodeSpec):
    """A golden scenario file: an episode specification and the seeds it runs over."""

    seeds: int | list[int] = Field(
        default=DEFAULT_SEEDS, description="a count of seeds from `seed` on, or the list of seeds to run")

    @field_validator("seeds")
    @classmethod
    def _check_seeds(cls, v: int | list[int]) -> int | list[int]:
        if isinstance(v, int) and not 1 <= v <= 1000:
            raise ValueError(f"a seed count must be 1 to 1000, given {v}")
        if isinstance(v, list) and (not v or len(set(v)) != len(v) or min(v) < 0):
            raise ValueError(f"a seed list must be non-empty, without repeats and >= 0, given {v}")
        return v


@dataclasses.dataclass(frozen=True)
class Golden:
    """One golden scenario: its specification (at its first seed), the seeds it runs over, and the
    fields its file gave (what another checkout validates with its own defaults)."""

    name: str
    spec: EpisodeSpec
    seeds: tuple[int, ...]
    fields: dict[str, Any]

    def job(self, seed: int) -> dict[str, Any]:
        """The JSON-ready job of one seed for :mod:`excavsim.studies.regress.against`."""
        return {"name": self.name, "spec": {**self.fields, "seed": seed}}


def parse_seeds(text: str) -> int | list[int]:
    """``--seeds``: ``N`` (a count from each scenario's ``seed``), ``A-B`` (A to B inclusive) or
    ``a,b,c`` (a list).

    Raises:
        ConfigError: anything else.
    """
    bad = ConfigError(f"--seeds: give a count N, a range A-B or a list a,b,c of seeds >= 0; given {text!r}")
    try:
        if "," in text:
            seeds = [int(s) for s in text.split(",") if s.strip()]
        elif "-" in text:
            lo, hi = (int(s) for s in text.split("-", 1))
            seeds = list(range(lo, hi + 1))
        else:
            n = int(text)
            if n < 1:
                raise bad
            return n
    except ValueError:
        raise bad from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise bad
    return seeds


def load_scenarios(directory: pathlib.Path = REGRESS_DIR, *, only: list[str] | None = None,
                   seeds: int | list[int] | None = None) -> dict[str, Golden]:
    """The golden scenarios of ``directory`` by file stem (those of ``only``, if given), each with its
    seeds (``seeds`` overrides every file's).

    Raises:
        ExcavsimError: no scenario files, or a name of ``only`` that is not one (the message lists them).
        ConfigError: a scenario file is invalid.
    """
    directory = pathlib.Path(directory)
    files = {f.stem: f for f in sorted(directory.glob("*.yaml"))}
    if not files:
        raise ConfigError(f"no regression scenarios (*.yaml) in {directory}")
    if only:
        unknown = [n for n in only if n not in files]
        if unknown:
            raise ConfigError(f"unknown scenario(s) {', '.join(unknown)} in {directory}; "
                              f"the scenarios are: {', '.join(files)}")
        files = {n: f for n, f in files.items() if n in only}
    out = {}
    for name, path in files.items():
        golden = load_config(path, GoldenScenario)
        choice = golden.seeds if seeds is None else seeds
        seed_list = tuple(range(golden.seed, golden.seed + choice)) if isinstance(choice, int) else tuple(choice)
        fields = golden.model_dump(mode="json", exclude_unset=True, exclude={"seeds"})
        spec = EpisodeSpec.model_validate(golden.model_dump(exclude={"seeds"}))
        out[name] = Golden(name, spec, seed_list, fields)
    return out


@dataclasses.dataclass
class Sample:
    """One scenario's per-seed results: ``rows[i]`` holds the summary of ``seeds[i]`` (for a
    baseline, only the stored keys: the task's metrics, ``end`` and ``sim_s``)."""

    seeds: list[int]
    rows: list[dict[str, Any]]
    task: str  # whose metrics are judged (task_metrics)

    def values(self, key: str) -> list | None:
        """Each seed's value of ``key``, or None when some row lacks it."""
        if any(key not in r for r in self.rows):
            return None
        return [r[key] for r in self.rows]

    def ends(self) -> dict[str, int]:
        """How many episodes ended by each stopping rule."""
        return dict(sorted(Counter(r.get("end", "?") for r in self.rows).items()))

    def mean(self, key: str) -> float | None:
        """The mean of ``key`` over the seeds (None when missing)."""
        v = self.values(key)
        return sum(v) / len(v) if v else None


def _episode_line(prefix: str, name: str, seed: int, r: dict, task: str | None = None) -> str:
    """One episode's progress line, in its task's words (``task`` default: the summary's)."""
    task = task or r.get("task")
    wall = r.get("wall_s")
    wall_text = f"{wall:.1f}" if isinstance(wall, int | float) else "?"
    return (f"{prefix}{name} seed {seed}: {catalog.progress_text(r, task)}, ended {r.get('end', '?')} "
            f"({wall_text} s wall)")


def run_goldens(goldens: dict[str, Golden], *, seeds_of: dict[str, Golden] | None = None, label: str = "",
                progress: Callable[[str], None] | None = print) -> dict[str, Sample]:
    """Run every scenario of ``goldens`` at each of its seeds (or at the seeds of the same-named
    scenario of ``seeds_of``) in this process; progress gets one line per episode."""
    plan = [(g, s) for g in goldens.values() for s in (seeds_of or goldens)[g.name].seeds]
    rows: dict[str, dict[int, dict]] = {g: {} for g in goldens}
    for i, (g, seed) in enumerate(plan, start=1):
        spec = EpisodeSpec.model_validate({**g.spec.model_dump(), "seed": seed})  # checks the seed's range
        rows[g.name][seed] = episode_summary(run_spec(spec), spec.task)
        if progress:
            progress(_episode_line(f"{label}[{i}/{len(plan)}] ", g.name, seed, rows[g.name][seed], spec.task))
    return {name: Sample(list(r), list(r.values()), goldens[name].spec.task) for name, r in rows.items()}


# -- the baseline file ---------------------------------------------------------------------------------
def write_baseline(path: pathlib.Path, samples: dict[str, Sample]) -> None:
    """Write the baseline atomically (a temporary file renamed over the old one): per scenario its
    seeds, each seed's end and simulated time, and per metric :func:`~regress_stats.summarize`."""
    doc = {"format": BASELINE_FORMAT,
           "written_by": "excavsim regress --update (per-seed values; see excavsim.studies.regress.suite)",
           "scenarios": {}}
    for name, sample in sorted(samples.items()):
        doc["scenarios"][name] = {
            "seeds": sample.seeds, "end": sample.values("end"), "sim_s": sample.values("sim_s"),
            "metrics": {m: rs.summarize(sample.values(m)) for m in task_metrics(sample.task)
                        if sample.values(m) is not None}, "task": sample.task}
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".baseline-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(_json_safe(doc), fh, indent=1, sort_keys=True, allow_nan=False)
        fh.write("\n")
    os.replace(tmp, path)


def load_baseline(path: pathlib.Path) -> dict[str, Sample]:
    """The baseline's samples by scenario.

    Raises:
        DataFileError: the file is missing, not JSON, in another format or with a malformed entry (the
            message names it and says how to write it).
    """
    path = pathlib.Path(path)
    rewrite = "write it with `excavsim regress --update` (or compare two checkouts with --against REF, " \
              "which needs no baseline)"
    if not path.exists():
        raise DataFileError(f"no baseline at {path}; {rewrite}")
    try:
        doc = json.loads(read_text_file(path, "baseline"))
    except ConfigError as exc:  # not a readable text file (the message names it)
        raise DataFileError(f"{exc}; re{rewrite}") from None
    except (ValueError, RecursionError) as exc:
        raise DataFileError(f"{path}: not valid JSON ({type(exc).__name__}: {shorten(exc)}); re{rewrite}") from None
    if not isinstance(doc, dict) or doc.get("format") != BASELINE_FORMAT:
        raise DataFileError(f"{path} is not a distribution baseline (format {BASELINE_FORMAT}; older baselines "
                            f"held one episode per scenario); re{rewrite}")
    out = {}
    try:
        for name, sc in doc["scenarios"].items():
            n = len(sc["seeds"])
            rows = [{} for _ in range(n)]
            columns = {"end": sc.get("end"), "sim_s": sc.get("sim_s"),
                       **{m: st["values"] for m, st in sc.get("metrics", {}).items()}}
            for key, vals in columns.items():
                if vals is not None and len(vals) == n:
                    for row, v in zip(rows, vals, strict=True):
                        row[key] = v
            out[name] = Sample(list(sc["seeds"]), rows, sc["task"])
    except (KeyError, TypeError, AttributeError, ValueError) as exc:  # a field missing or of another shape
        raise DataFileError(f"{path}: a scenario entry is malformed ({type(exc).__name__}: {shorten(exc)}); "
                            f"re{rewrite}") from None
    return out


# -- comparing samples ---------------------------------------------------------------------------------
@dataclasses.dataclass
class Comparison:
    """One metric of one scenario: the two samples' statistics and the judgement.

    ``verdict`` is that of :func:`~regress_stats.judge` ("regression", "improved", "ok", "same"),
    or "new" (no reference values) or "missing" (a reference scenario that was not run; ``metric``
    is "-").
    """

    scenario: str
    metric: str
    baseline: dict | None
    now: dict | None
    judgement: rs.Judgement | None
    verdict: str


def compare(reference: dict[str, Sample], now: dict[str, Sample], *, paired: bool = False,
            partial: bool = False) -> list[Comparison]:
    """Every judged metric of every scenario of ``now`` against ``reference``.

    Args:
        paired: both sides ran the same seeds on one machine (A/B); rows are matched by seed.
        partial: only some scenarios ran (``--only``): the reference's others are not "missing".
    """
    out = []
    for name, cur in now.items():
        ref = reference.get(name)
        if paired and ref is not None:
            by_seed = dict(zip(ref.seeds, ref.rows, strict=True))
            ref = Sample(cur.seeds, [by_seed[s] for s in cur.seeds], cur.task)
        for metric, rule in task_metrics(cur.task).items():
            now_v = cur.values(metric)
            ref_v = ref.values(metric) if ref is not None else None
            now_s = rs.summarize(now_v) if now_v else None
            if not ref_v or not now_v:
                out.append(Comparison(name, metric, rs.summarize(ref_v) if ref_v else None, now_s, None, "new"))
                continue
            ref_s = rs.summarize(ref_v)
            j = rs.judge(ref_v, now_v, higher_is_better=rule.better == "higher",
                         tolerance=rule.tolerance(ref_s["mean"]), paired=paired)
            out.append(Comparison(name, metric, ref_s, now_s, j, j.verdict))
    if not partial:
        out += [Comparison(name, "-", None, None, None, "missing") for name in reference if name not in now]
    return out


def failures(comparisons: list[Comparison]) -> list[Comparison]:
    """The comparisons that fail the suite: regressions and missing scenarios."""
    return [c for c in comparisons if c.verdict in ("regression", "missing")]


# -- the report ----------------------------------------------------------------------------------------
@dataclasses.dataclass
class Report:
    """The outcome of a regression run: which mode, against what, the samples and the comparisons."""

    mode: str  # "baseline" or "against"
    source: str  # the baseline file, or the git ref / directory compared with
    baseline: dict[str, Sample]
    now: dict[str, Sample]
    comparisons: list[Comparison]

    @property
    def failed(self) -> list[Comparison]:
        """Regressions and missing scenarios (the suite fails when there are any)."""
        return failures(self.comparisons)

    def test_text(self) -> str:
        """The statistical test used, in words."""
        if self.mode == "against":
            return (f"paired by seed: one-sided Wilcoxon signed-rank test of the per-seed difference beyond the "
                    f"tolerance (p < {rs.ALPHA}) and the {rs.CONFIDENCE:.0%} bootstrap interval of the mean "
                    f"difference entirely beyond the tolerance")
        return (f"unpaired: one-sided Mann-Whitney U test of now against the baseline moved by the tolerance "
                f"(p < {rs.ALPHA}) and the {rs.CONFIDENCE:.0%} bootstrap interval of the difference of the means "
                f"entirely beyond the tolerance")

    def format(self, *, show_seeds: bool = False) -> str:
        """The human-readable table: per scenario a line of ends and timings, then per metric the
        baseline and now (mean ± sd), the difference with its interval, the p-value and the verdict."""
        base_label = "REF" if self.mode == "against" else "baseline"
        lines = ([f"REF = {self.source}"] if self.mode == "against" else []) + [f"regression = {self.test_text()}"]
        head = (f"  {'metric':<20} {base_label + ' mean ± sd':>19} {'now mean ± sd':>19}   "
                f"{'now - ' + base_label + ' [' + format(rs.CONFIDENCE, '.0%') + ' interval]':<32} {'p':>6}  verdict")
        by_scenario: dict[str, list[Comparison]] = {}
        for c in self.comparisons:
            by_scenario.setdefault(c.scenario, []).append(c)
        for name, rows in by_scenario.items():
            lines.append("")
            if rows[0].verdict == "missing":
                lines.append(f"{name}: in the baseline but not run: missing (remove it with --update)")
                continue
            lines += self._scenario_lines(name)
            lines.append(head)
            for c in rows:
                lines.append(_row(c))
                if show_seeds:
                    lines.append(f"    per seed {base_label}: {_vals(c.baseline)}")
                    lines.append(f"    per seed now: {_vals(c.now)}")
        return "\n".join(lines)

    def _scenario_lines(self, name: str) -> list[str]:
        cur, ref = self.now[name], self.baseline.get(name)
        base_label = "REF" if self.mode == "against" else "baseline"
        out = [f"{name}: seeds {_seed_text(cur.seeds)}"
               + (f" (baseline seeds {_seed_text(ref.seeds)})" if ref and ref.seeds != cur.seeds else "")
               + f"; ended {_ends(cur.ends())}" + (f" ({base_label}: {_ends(ref.ends())})" if ref else "")]
        timing = ", ".join(f"{k.removesuffix('_s')} {cur.mean(k):.2f} s" for k in TIMINGS if cur.mean(k) is not None)
        ref_timing = ", ".join(f"{k.removesuffix('_s')} {ref.mean(k):.2f} s" for k in TIMINGS
                               if ref and ref.mean(k) is not None)
        out.append(f"  timings per episode (never judged): {timing}" + (f"; {base_label} {ref_timing}" if ref_timing
                                                                       else ""))
        if ref and rs.smallest_p(len(ref.seeds), len(cur.seeds), paired=self.mode == "against") >= rs.ALPHA:
            out.append(f"  note: with {len(ref.seeds)} and {len(cur.seeds)} seeds the test cannot reach "
                       f"p < {rs.ALPHA}: nothing can be flagged; run more seeds (--seeds)")
        return out

    def to_json(self) -> dict:
        """The machine-readable result (strict JSON: no NaN)."""
        scen: dict[str, dict] = {}
        for c in self.comparisons:
            if c.verdict == "missing":
                scen[c.scenario] = {"verdict": "missing"}
                continue
            if c.scenario not in scen:
                cur, ref = self.now[c.scenario], self.baseline.get(c.scenario)
                scen[c.scenario] = {
                    "seeds": cur.seeds, "baseline_seeds": ref.seeds if ref else None,
                    "end": {"baseline": ref.ends() if ref else None, "now": cur.ends()},
                    "timings_s": {"baseline": {k: ref.mean(k) for k in TIMINGS if ref and ref.mean(k) is not None},
                                  "now": {k: cur.mean(k) for k in TIMINGS if cur.mean(k) is not None}},
                    "metrics": {}}
            j = c.judgement
            scen[c.scenario]["metrics"][c.metric] = {
                "better": task_metrics(self.now[c.scenario].task)[c.metric].better, "baseline": c.baseline,
                "now": c.now,
                "tolerance": j.tolerance if j else None, "difference": j.difference if j else None,
                "interval": list(j.interval) if j else None, "p_value": j.p_value if j else None,
                "p_improved": j.p_improved if j else None, "verdict": c.verdict}
        return _json_safe({
            "mode": self.mode, "baseline_source": self.source, "test": self.test_text(), "alpha": rs.ALPHA,
            "confidence": rs.CONFIDENCE, "verdict": "regression" if self.failed else "no regression",
            "failed": [{"scenario": c.scenario, "metric": c.metric, "verdict": c.verdict} for c in self.failed],
            "scenarios": scen})


def _num(v: float) -> str:
    return f"{v:.3f}" if abs(v) < 1e4 else f"{v:.4g}"


def _row(c: Comparison) -> str:
    def stat(s):
        return "-" if s is None else f"{_num(s['mean'])} ± {_num(s['std'])}"

    j = c.judgement
    diff = "-" if j is None else f"{j.difference:+.3f} [{j.interval[0]:+.3f}, {j.interval[1]:+.3f}]"
    p = "-" if j is None else f"{j.p_value:.3f}"
    return f"  {c.metric:<20} {stat(c.baseline):>19} {stat(c.now):>19}   {diff:<32} {p:>6}  {c.verdict}"


def _vals(s: dict | None) -> str:
    return "-" if s is None else " ".join(_num(v) for v in s["values"])


def _ends(counts: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in counts.items())


def _seed_text(seeds: list[int]) -> str:
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}-{seeds[-1]}"
    return ",".join(map(str, seeds))


def _json_safe(obj):
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_safe(v) for v in obj]
    return obj


# -- the two modes -------------------------------------------------------------------------------------
def run_regress(directory: pathlib.Path = REGRESS_DIR, *, baseline_path: pathlib.Path | None = None,
                update: bool = False, only: list[str] | None = None, seeds: int | list[int] | None = None,
                progress: Callable[[str], None] | None = print) -> Report:
    """Baseline mode: run the golden scenarios over their seeds and compare with the baseline (with
    ``update``, then rewrite it; scenarios not run keep their baseline entries).

    Raises:
        ExcavsimError: no scenarios, an unknown name in ``only``, or (without ``update``) a missing or
            unreadable baseline.
    """
    directory = pathlib.Path(directory)
    baseline_path = pathlib.Path(baseline_path or directory / BASELINE_NAME)
    goldens = load_scenarios(directory, only=only, seeds=seeds)
    if not update or only:
        baseline = load_baseline(baseline_path)  # --update --only merges into it, so it must be readable
    else:
        try:
            baseline = load_baseline(baseline_path)
        except ExcavsimError:
            baseline = {}  # replaced as a whole
    now = run_goldens(goldens, progress=progress)
    report = Report("baseline", str(baseline_path), baseline, now, compare(baseline, now, partial=bool(only)))
    if update:
        write_baseline(baseline_path, {**baseline, **now} if only else now)
    return report


def run_against(directory: pathlib.Path = REGRESS_DIR, *, ref: str | None = None,
                against_dir: pathlib.Path | None = None, only: list[str] | None = None,
                seeds: int | list[int] | None = None, progress: Callable[[str], None] | None = print) -> Report:
    """A/B mode: the golden scenarios of ``directory`` at the same seeds, run with the code at git
    ``ref`` (in a temporary worktree and a subprocess, at the same time as this run) or with the
    same-named scenarios of ``against_dir`` (in this process), and with the working tree; compared
    paired by seed.

    Raises:
        ExcavsimError: neither or both of ``ref`` and ``against_dir``, an unknown scenario, a git ref
            that does not exist, or a failed run at ``ref``.
    """
    if (ref is None) == (against_dir is None):
        raise UsageError("run_against needs exactly one of a git ref and a scenario directory")
    goldens = load_scenarios(directory, only=only, seeds=seeds)
    if against_dir is not None:
        others = load_scenarios(against_dir)
        absent = [n for n in goldens if n not in others]
        if absent:
            raise ConfigError(f"{against_dir} lacks the scenario(s) {', '.join(absent)} of {directory}; "
                              f"it has: {', '.join(others)}")
        reference = run_goldens({n: others[n] for n in goldens}, seeds_of=goldens, label=f"{against_dir} ",
                                progress=progress)
        now = run_goldens(goldens, label="now ", progress=progress)
        return Report("against", f"the scenarios of {against_dir}", reference, now,
                      compare(reference, now, paired=True))
    from excavsim.studies.regress.against import CheckoutRun, ref_checkout, resolve_ref

    commit = resolve_ref(ref)
    jobs = [g.job(s) for g in goldens.values() for s in g.seeds]
    label = f"{ref} ({commit[:10]})"
    counter = iter(range(1, len(jobs) + 1))

    def arrived(name: str, seed: int, summary: dict) -> None:
        if progress:
            progress(_episode_line(f"{ref} [{next(counter)}/{len(jobs)}] ", name, seed, summary,
                                   goldens[name].spec.task))

    with ref_checkout(commit) as checkout, CheckoutRun(checkout, jobs, label=label, on_result=arrived,
                                                       aliases=catalog_aliases()) as run:
        now = run_goldens(goldens, label="now ", progress=progress)
        found = run.results()
    reference = {n: Sample(list(g.seeds), [found[(n, s)] for s in g.seeds], g.spec.task) for n, g in goldens.items()}
    return Report("against", f"git {label}", reference, now, compare(reference, now, paired=True))
