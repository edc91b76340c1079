"""``configs/regress/baseline.json``: the regression baseline's format (``excavsim regress --update`` writes it).

Format 2: per golden scenario its seeds, each seed's end and simulated time, and per metric the
sample's statistics with its per-seed values (``excavsim.studies.regress.stats.summarize``); numbers that
were not finite are written as ``null``. :func:`load_baseline_file` reads and checks the file (every
list one value per seed, each metric's ``n`` its count) for ``excavsim validate``.
"""

from __future__ import annotations

import json
import pathlib
from typing import Literal

from pydantic import Field, model_validator

from excavsim.config.loader import StrictModel, display_path, parse_config, read_text_file
from excavsim.errors import ConfigError, shorten

BASELINE_FORMAT = 2  # the format ``excavsim regress`` writes and reads


class MetricSummary(StrictModel):
    """One metric's sample over the scenario's seeds: its statistics and its values (``null``: not finite)."""

    n: int = Field(ge=1, le=100_000, description="number of values (one per seed)")
    mean: float | None = None
    std: float | None = None
    min: float | None = None
    q10: float | None = None
    q25: float | None = None
    median: float | None = None
    q75: float | None = None
    q90: float | None = None
    max: float | None = None
    values: list[float | None] = Field(min_length=1, description="the per-seed values, in the order of seeds")

    @model_validator(mode="after")
    def _count(self) -> MetricSummary:
        if len(self.values) != self.n:
            raise ValueError(f"n={self.n} but {len(self.values)} values; allowed: n equal to the number of values")
        return self


class ScenarioBaseline(StrictModel):
    """One golden scenario's sample: its seeds, each seed's end and simulated time [s], its metrics."""

    seeds: list[int] = Field(min_length=1, description="the seeds run, distinct, >= 0")
    task: str = Field(pattern=r"^[a-z][a-z0-9_]{0,39}$",
                      description="the scenario's task (a name of the catalog), whose metrics are judged")
    end: list[str | None] | None = Field(default=None, description="each seed's end (done, budget, ...)")
    sim_s: list[float | None] | None = Field(default=None, description="each seed's simulated time [s]")
    metrics: dict[str, MetricSummary] = Field(default_factory=dict, description="per metric its sample")

    @model_validator(mode="after")
    def _per_seed(self) -> ScenarioBaseline:
        n = len(self.seeds)
        if min(self.seeds) < 0 or len(set(self.seeds)) != n:
            raise ValueError(f"seeds {shorten(self.seeds)}; allowed: distinct integers >= 0")
        for key, vals in (("end", self.end), ("sim_s", self.sim_s),
                          *((f"metrics.{m}.values", s.values) for m, s in self.metrics.items())):
            if vals is not None and len(vals) != n:
                raise ValueError(f"{key} holds {len(vals)} values for {n} seeds; allowed: one value per seed")
        return self


class RegressBaseline(StrictModel):
    """``configs/regress/baseline.json``: the baseline of the golden scenarios (format 2)."""

    format: Literal[2] = Field(description="the baseline format; older baselines held one episode per scenario")
    written_by: str | None = Field(default=None, description="what wrote the file")
    scenarios: dict[str, ScenarioBaseline] = Field(min_length=1, description="per golden scenario its sample")


def load_baseline_file(path: str | pathlib.Path) -> RegressBaseline:
    """Read and check a regression baseline (JSON).

    Raises:
        ConfigError: naming the file, the field and what is allowed (or why the file is no JSON).
    """
    where = display_path(path)
    text = read_text_file(path, "baseline", where=where)
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise ConfigError(f"{where}: not valid JSON ({shorten(exc, 200)}); allowed: a baseline written by "
                          "`excavsim regress --update`") from None
    return parse_config(doc, RegressBaseline, source=where)
