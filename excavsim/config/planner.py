"""``configs/planner.yaml`` and ``configs/trenches/*.yaml``: the planner's rules, grid and objective; trench goals."""

from __future__ import annotations

import math
import pathlib

from pydantic import Field, model_validator

from excavsim import constants
from excavsim.config.loader import StrictModel, load_config

class TrenchGoal(StrictModel):
    """``configs/trenches/*.yaml``: a trench to dig, as a 2-D profile in the arm plane (§3.4, Fig. 37).

    The arm plane is set by ``waist_deg``; x is the radial distance from the waist axis. The trench
    opens between ``near_x_m`` (towards the robot) and ``far_x_m`` at ``surface_z_m`` and goes down
    ``depth_m``, with walls at the given angles from horizontal (90 = vertical). Its width is the
    bucket's. Nothing below the profile may be cut; above it everything may.
    """

    name: str = Field(default="", description="label for logs")
    waist_deg: float = Field(default=0.0, ge=-45, le=100, description="waist angle of the arm plane [deg]")
    near_x_m: float = Field(gt=0, le=15, description="radial distance of the trench's near edge [m] (up to a 25 t excavator's reach)")
    far_x_m: float = Field(gt=0, le=15, description="radial distance of the trench's far edge [m]")
    surface_z_m: float = Field(default=0.5, ge=0, le=1.4, description="height the depth is measured from [m]")
    depth_m: float = Field(gt=0, le=3.0, description="depth of the trench bottom [m]")
    near_wall_deg: float = Field(default=60.0, gt=0, le=90, description="near wall angle from horizontal [deg]")
    far_wall_deg: float = Field(default=60.0, gt=0, le=90, description="far wall angle from horizontal [deg]")

    @model_validator(mode="after")
    def _order(self) -> TrenchGoal:
        if self.far_x_m <= self.near_x_m:
            raise ValueError(f"far_x_m={self.far_x_m} must be greater than near_x_m={self.near_x_m}")
        return self


PLANNER_MEMORY_BYTES = 4 << 30  # the most working memory a plan may need (estimated before planning) [bytes]
_BYTES_PER_SAMPLE = 192  # working memory per grid cell and path sample: 24 float64, measured on planner.yaml


def _axis_len(lo: float, hi: float, step: float) -> float:
    """Points of a grid axis from ``lo`` to ``hi`` every ``step`` (as the planner builds it), as a float."""
    return math.floor((hi - lo) / step + 1e-9) + 1.0


class PlannerGrid(StrictModel):
    """The discretized action space (k, alpha, d1) of the trenching action (§3.4.1, ch. 6)."""

    k_min_m: float = Field(default=1.4, gt=0, le=15)
    k_max_m: float = Field(default=3.3, gt=0, le=15)
    k_step_m: float = Field(default=0.1, gt=0, le=1)
    alpha_min_deg: float = Field(default=0.0, ge=0, le=89)
    alpha_max_deg: float = Field(default=45.0, ge=0, le=89)
    alpha_step_deg: float = Field(default=5.0, gt=0, le=45)
    d1_min_m: float = Field(default=0.02, gt=0, le=1)
    d1_max_m: float = Field(default=0.50, gt=0, le=3)
    d1_step_m: float = Field(default=0.01, gt=0, le=0.5)

    @model_validator(mode="after")
    def _ranges(self) -> PlannerGrid:
        for lo, hi in (("k_min_m", "k_max_m"), ("alpha_min_deg", "alpha_max_deg"), ("d1_min_m", "d1_max_m")):
            if getattr(self, lo) > getattr(self, hi):
                raise ValueError(f"{lo}={getattr(self, lo)} exceeds {hi}={getattr(self, hi)}")
        return self

    @property
    def shape(self) -> tuple[float, float, float]:
        """Points along k, alpha and d1 (floats: a tiny step gives a number too large to allocate)."""
        return (_axis_len(self.k_min_m, self.k_max_m, self.k_step_m),
                _axis_len(self.alpha_min_deg, self.alpha_max_deg, self.alpha_step_deg),
                _axis_len(self.d1_min_m, self.d1_max_m, self.d1_step_m))


SEARCHES = ("exhaustive", "anneal")


class PlannerConfig(StrictModel):
    """``configs/planner.yaml``: the trenching action's rules, the search grid and the objective."""

    epsilon_deg: float = Field(default=10.0, ge=0, le=45, description="rake = alpha + epsilon while penetrating")
    omega_deg_per_m: float = Field(default=50.0, ge=0, le=500, description="rake decrease per metre of drag")
    zeta_deg: float = Field(default=8.0, ge=-30, le=60, description="smallest rake during the drag, zeta(omega)")
    sample_spacing_m: float = Field(default=0.025, gt=0, le=0.2, description="trajectory sample spacing [m]")
    d2_max_m: float = Field(default=1.2, gt=0, le=6, description="longest drag considered [m]")
    curl_end_pitch_deg: float = Field(default=-30.0, ge=-120, le=60, description="pitch at the end of the curl")
    curl_radii_m: list[float] = Field(default=[0.35, 0.4, 0.5, 0.6, 0.8], min_length=1, max_length=20,
                                      description="curl radii tried, smallest first (§3.4.2.4)")
    curl_samples: int = Field(default=10, ge=2, le=100, description="samples along the curl")
    curl_exit_pitch_deg: float = Field(
        default=0.0, ge=-120, le=60, description="the pitch the bucket must have reached when its edge leaves the soil"
    )
    fill_fraction: float = Field(default=1.0, gt=0, le=2, description="volume limit as a fraction of capacity")
    volume_constraint: bool = Field(default=True, description="apply the volume constraint (§4.3.2); off, only "
                                    "the force constraint keeps digs to what the bucket can take (§7.2.2)")
    heaped_capacity_factor: float = Field(default=1.25, ge=1, le=2, description="the load the bucket holds before "
                                          "cut soil stays ahead of it, x struck capacity (the force model's belief)")
    objective: str = Field(default="lexicographic",
                           description="volume | peak_torque | cumulative_torque | lexicographic (eq. 44)")
    volume_threshold: float = Field(default=0.9, ge=0, le=2,
                                    description="eq. 44: digs must sweep more than this fraction of capacity")
    auxiliary: str = Field(default="peak_torque", description="eq. 44's auxiliary criterion J2 among the digs over "
                           "the volume threshold: peak_torque | cumulative_torque")
    min_volume_fraction: float = Field(default=0.05, ge=0, le=1, description="below this: no dig")
    search: str = Field(default="exhaustive", description="how plan() searches the grid: exhaustive (ch. 6) | "
                        "anneal (simulated annealing, §6.3: excavsim.planning.anneal)")
    anneal_iterations: int = Field(default=20, ge=0, le=10_000, description="search: anneal: iterations per plan")
    anneal_chains: int = Field(default=16, ge=1, le=1024, description="search: anneal: Metropolis chains")
    anneal_seed: int = Field(default=0, ge=0, description="search: anneal: seed of the planner's annealing generator "
                             "(one per planner: an episode's plans draw from it in turn)")
    shaping_tolerance_m: float = Field(default=0.005, ge=0, le=0.1)
    fallback_clearance_m: float = Field(default=0.01, ge=0, le=0.2,
                                        description="boundary-following digs stay this far above the goal [m]")
    fallback_bottom_step_m: float = Field(default=0.1, gt=0, le=1, description="spacing of bottom fallback digs [m]")
    fallback_min_volume_fraction: float = Field(default=0.02, ge=0, le=1,
                                                description="a boundary dig must sweep this fraction of capacity")
    surface_tolerance_m: float = Field(default=0.01, ge=0, le=0.2)
    wall_clearance_m: float = Field(default=0.05, ge=0, le=0.5,
                                    description="the bucket keeps this far from the soil box's walls [m]")
    touchdown_reach_m: float = Field(default=0.05, ge=0, le=0.5,
                                     description="the arm must reach this far below a dig's entry (touch-down) [m]")
    payload_com_tip_m: list[float] = Field(default=[-0.2, 0.12], min_length=2, max_length=2,
                                           description="centre of the load in the tip frame (x, z) [m]")
    grid: PlannerGrid = PlannerGrid()

    def volume_limit_m3(self, capacity_m3: float) -> float:
        """The volume constraint's largest swept volume for a bucket of ``capacity_m3`` [m^3]
        (``inf`` with the constraint off)."""
        return self.fill_fraction * capacity_m3 if self.volume_constraint else math.inf

    def path_samples(self) -> float:
        """Samples along one planned path: penetration to the longest d1, drag to ``d2_max_m``, curl."""
        ds = self.sample_spacing_m
        return math.ceil(self.grid.d1_max_m / ds) + 1 + math.floor(self.d2_max_m / ds + 1e-9) + 1 + self.curl_samples

    def estimated_bytes(self) -> float:
        """Working memory a plan needs, estimated from the grid's cells and the samples along each path [bytes]
        (the search holds every cell's path and its forces at once)."""
        nk, na, nd = self.grid.shape
        return nk * na * nd * self.path_samples() * _BYTES_PER_SAMPLE

    @model_validator(mode="after")
    def _memory(self) -> PlannerConfig:
        need = self.estimated_bytes()
        if need > PLANNER_MEMORY_BYTES:
            nk, na, nd = self.grid.shape
            size = f"about {need / 2**30:.3g} GiB" if math.isfinite(need) else "more memory than any machine has"
            raise ValueError(
                f"the search would need {size} ({nk * na * nd:.3g} cells x "
                f"{self.path_samples():.3g} path samples); allowed: at most {PLANNER_MEMORY_BYTES / 2**30:g} GiB "
                "(raise sample_spacing_m or grid.k_step_m, grid.alpha_step_deg, grid.d1_step_m)")
        return self

    @model_validator(mode="after")
    def _objective(self) -> PlannerConfig:
        allowed = ("volume", "peak_torque", "cumulative_torque", "lexicographic")
        if self.objective not in allowed:
            raise ValueError(f"objective={self.objective!r}; allowed: {', '.join(allowed)}")
        if self.search not in SEARCHES:
            raise ValueError(f"search={self.search!r}; allowed: {', '.join(SEARCHES)}")
        if self.auxiliary not in ("peak_torque", "cumulative_torque"):
            raise ValueError(f"auxiliary={self.auxiliary!r}; allowed: peak_torque, cumulative_torque")
        if sorted(self.curl_radii_m) != list(self.curl_radii_m) or min(self.curl_radii_m) <= 0:
            raise ValueError(f"curl_radii_m={self.curl_radii_m} must be positive and increasing")
        if max(self.curl_radii_m) > 3:
            raise ValueError(f"curl_radii_m={self.curl_radii_m}: allowed radii up to 3 m (the arm's reach)")
        if not all(abs(v) <= 1 for v in self.payload_com_tip_m):
            raise ValueError(f"payload_com_tip_m={self.payload_com_tip_m}: allowed within 1 m of the tip per axis")
        return self


def load_planner_config(path: str | pathlib.Path | None = None) -> PlannerConfig:
    """Load ``configs/planner.yaml`` (or ``path``)."""
    return load_config(path or constants.PLANNER_YAML, PlannerConfig)


def load_trench_goal(path: str | pathlib.Path) -> TrenchGoal:
    """Load a trench goal (``configs/trenches/*.yaml``)."""
    return load_config(path, TrenchGoal)
