"""One world protocol and one scan-to-map for every task: the trenching and the loading worlds."""

from __future__ import annotations

import numpy as np

from excavsim.config import load_sensing_config
from excavsim.sensing.elevation import map_accuracy, scan_map
from excavsim.world.facade import World


def test_the_trenching_and_the_loading_world_are_one_protocol_and_scan_into_maps_alike():
    from excavsim.tasks.pile_loading import task as lm
    from excavsim.rig.core import make_rig
    from excavsim.tasks.pile_loading.world.scene import LoadingWorld
    from excavsim.world.simulation import Simulation

    sim = Simulation(seed=0)
    loading = LoadingWorld("loader", seed=0)
    cfg = lm.load_mujoco_config()
    loading.set_terrain(loading.section_heights(*lm.pile_section(loading, cfg.pile)))
    for world in (sim, loading):
        assert isinstance(world, World)
        v = world.volumes()
        assert v.bucket == 0.0 and abs(v.total - world.soil.initial_volume) < 1e-9 * max(v.total, 1.0)
    assert not isinstance(object(), World)  # the protocol checks something

    map_cfg = load_sensing_config().map
    scanners = ((sim, make_rig(sim).scanner), (loading, lm.make_scanner(loading, cfg, 0)))
    for world, scanner in scanners:
        emap, cals = scan_map(scanner, world.time, map_cfg, n_scans=2)
        assert len(cals) == 2 and np.all(np.isfinite(emap.heights))
        acc = map_accuracy(emap, world.soil.grid.surface_z, cals)
        # the map is the terrain, a few cm off (the pile hides part of the lane from the scanner: filled)
        assert abs(acc.mean_m) < 0.01 and acc.rms_m < 0.1, (type(world).__name__, acc)
