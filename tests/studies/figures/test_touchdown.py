"""Touch-down on the testbed arm (Singh 1995 §7.1.3, Fig. 104) and Fig. 100's scale-error digs."""

from __future__ import annotations

import numpy as np
import pytest

from excavsim.config import load_scene_config
from excavsim.studies.figures import scale_dig as sd
from excavsim.studies.figures import touchdown as td
from excavsim.world.simulation import Simulation


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_ringing_arm_fools_the_old_touch_down_and_the_coping_one_finds_the_surface(seed):
    """On the testbed arm the ringing after the move above the entry reads as contact in the air (Fig. 104);
    with the quiet wait and the give compensation the contact is found within the tolerance, as on the
    nominal arm with the old executor."""
    testbed = td.testbed_scene()
    nominal = td.touch_down(seed, "testbed_sand", 2.1, scene=load_scene_config())
    before = td.touch_down(seed, "testbed_sand", 2.1, scene=testbed)
    after = td.touch_down(seed, "testbed_sand", 2.1, scene=testbed, executor=td.coping_executor())
    assert nominal.outcome == "ok" and abs(nominal.error_m) < td.DEPTH_TOL_M
    assert before.outcome == "in air" and before.error_m > 0.05  # declared about 13 cm above the surface
    assert after.outcome == "ok" and abs(after.error_m) < td.DEPTH_TOL_M
    assert after.penetration_m > 0.0  # the bucket was in the soil when contact was declared


def test_without_the_give_compensation_the_found_surface_is_high_by_the_unseen_sag():
    testbed = td.testbed_scene()
    quiet = td.coping_executor(give=[0.0, 0.0, 0.0])
    sand = [td.touch_down(0, "testbed_sand", x, scene=testbed, executor=quiet) for x in (1.7, 1.9)]
    comp = [td.touch_down(0, "testbed_sand", x, scene=testbed, executor=td.coping_executor()) for x in (1.7, 1.9)]
    for s, c in zip(sand, comp):
        assert s.error_m - c.error_m > 0.004  # the encoders miss the arm's sag under its own weight: 0.5-1 cm


def test_calibrate_give_recovers_the_transmissions_compliance():
    """Surveyed tip poses under known loads give c / kp of the testbed arm (c = 1), and nothing on the nominal arm."""
    kp = Simulation().model.actuator_gainprm[[1, 2, 3], 0]
    give = td.calibrate_give(td.testbed_scene())  # the four entries, 0, 50 and 100 kg
    np.testing.assert_allclose(give, 1.0 / kp, rtol=0.05)
    assert np.all(np.abs(td.calibrate_give(load_scene_config(), entries=(1.9, 2.2))) < 0.05 / kp)


def test_fig100_the_unadjusted_dig_barely_engages_and_the_adjusted_one_digs_more_than_planned():
    d = sd.scale_dig(0)
    v = d.volumes
    assert v["a"] > 0.005  # a real dig on the map
    assert v["b"] < 0.2 * v["a"]  # (b): the map lies ~12 cm above the terrain, the bucket barely engages
    assert v["c"] > 1.05 * v["a"]  # (c): the adjusted map is low on the top, the bucket engages too aggressively
    assert v["c_planned"] == pytest.approx(v["a"], rel=1e-6)  # the same dig as the planner saw it
    exact = sd.scale_dig(0, scale=1.0)  # no scale error: all three are the same dig
    assert exact.volumes["b"] == pytest.approx(exact.volumes["a"], rel=1e-3)
    assert exact.volumes["c"] == pytest.approx(exact.volumes["a"], rel=1e-3)


def test_the_figures_draw_and_report(tmp_path):
    class Ctx:
        seed = 0

    text = sd.fig100(Ctx, tmp_path / "fig100.png")
    assert "(b) B's plan executed on A" in text and (tmp_path / "fig100.png").stat().st_size > 10_000
    text = td.fig104(Ctx, tmp_path / "fig104.png")
    assert "testbed arm, executor before: in air" in text and "testbed arm, executor after: ok" in text
    assert (tmp_path / "fig104.png").stat().st_size > 10_000


def test_the_coping_numbers_are_refused_by_name_when_bad():
    from pydantic import ValidationError

    from excavsim.config import ExecutorConfig

    for field, bad in (("joint_give_rad_per_nm", [0.0, -1e-6, 0.0]), ("joint_give_rad_per_nm", [0.0, 0.0]),
                       ("touch_quiet_s", -0.1), ("touch_quiet_n", 0.0)):
        with pytest.raises(ValidationError, match=field):
            ExecutorConfig.model_validate({field: bad})
