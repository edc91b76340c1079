"""What the robot's mind knows of its scanner and receives from it: plain numpy value types.

Kept apart from :mod:`excavsim.sensing.scanner` (which reads the true terrain through MuJoCo) so that
the map builder and the planner import no simulator.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class ScanGeometry:
    """What the robot knows about its scanner and the box (surveyed, §7.1.2).

    Attributes:
        origin: (3,) scanner position, world [m].
        directions: (n_el, n_az, 3) unit ray directions of the range image, world.
        target_directions: (n_targets, k, 3) rays aimed at points on each surveyed target plate.
        target_ranges: (n_targets, k) surveyed ranges along those rays [m].
        area: (x0, x1, y0, y1) the soil area inside the walls, world [m].
        wall_top_z: height of the walls' tops [m].
    """

    origin: np.ndarray
    directions: np.ndarray
    target_directions: np.ndarray
    target_ranges: np.ndarray
    area: tuple[float, float, float, float]
    wall_top_z: float

    @property
    def image_shape(self) -> tuple[int, int]:
        return self.directions.shape[:2]


@dataclasses.dataclass(frozen=True)
class RangeImage:
    """One scan: ranges along the image rays and the target rays [m]; NaN where there was no return."""

    time: float
    ranges: np.ndarray
    target_ranges: np.ndarray
