"""The testbed arm's compliance (excavsim.world.arm, Singh 1995 §7.1.3): ring-down and give against the model."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from excavsim.config import SceneConfig, load_config, load_scene_config
from excavsim.constants import CONFIGS_DIR
from excavsim.world.arm import mode_table
from excavsim.world.simulation import Simulation

ELBOW, WRIST = 2, 3


def scene(zeta=0.3, give=1.0) -> SceneConfig:
    s = load_scene_config()
    return s.model_copy(update={"truth": s.truth.model_copy(update={"arm_damping_ratio": zeta,
                                                                      "arm_give_share": give})})


def resting(sc: SceneConfig) -> Simulation:
    """A world whose arm has come to rest at home with its set-points held (soil off)."""
    sim = Simulation(scene=sc, seed=0)
    sim.soil_enabled = False
    for _ in range(200):
        sim.step(np.zeros(6))
    return sim


def test_the_servo_numbers_follow_the_stated_model():
    sim, nominal = Simulation(scene=scene(0.3, 1.0)), Simulation()
    at, m = sim.arm_truth, sim.model
    a, d = sim.index.actuator, sim.index.dof
    for k in (1, 2, 3):  # the planar joints: k_eff = kp / (1 + c), kv + b = 2 zeta sqrt(k_eff I)
        kp = nominal.model.actuator_gainprm[a[k], 0]
        assert m.actuator_gainprm[a[k], 0] == pytest.approx(kp / 2.0)
        assert -m.actuator_biasprm[a[k], 2] + m.dof_damping[d[k]] == pytest.approx(
            2 * 0.3 * np.sqrt(kp / 2.0 * at.inertia[k]))
        assert at.give[k] == pytest.approx(1.0 / kp)
    for k in (0, 4, 5):  # waist and wrist yaw/roll as robot.yaml has them
        np.testing.assert_array_equal(m.actuator_biasprm[a[k]], nominal.model.actuator_biasprm[a[k]])
        assert at.give[k] == 0.0
    assert Simulation().arm_truth is None  # off by default: the default world's model is untouched


@pytest.mark.parametrize("give", [0.0, 1.0])
def test_a_set_point_step_rings_at_the_linear_models_slowest_arm_mode(give):
    """Step the elbow's set-point by 5 mrad, hold every set-point: the elbow rings at the frequency and
    with the decay of the slowest arm mode of M q'' + C q' + K q = K sp (mode_table, held set-points)."""
    sim = resting(scene(0.3, give))
    modes = [mo for mo in mode_table(sim.model, sim.data, sim.index.actuator, sim.index.dof) if mo[1] < 0.6]
    f_model, zeta_model = modes[0]
    sim.data.act[sim.index.actuator[ELBOW]] += 0.005
    q = []
    for _ in range(150):
        sim.step(np.zeros(6))
        q.append(sim.data.qpos[sim.index.qpos[ELBOW]])
    x = np.asarray(q) - q[-1]
    zc = np.flatnonzero(np.diff(np.sign(x)) != 0)
    f = 1.0 / (2 * np.mean(np.diff(zc[:4])) * sim.control_dt)
    peaks = np.array([np.abs(x[i:j]).max() for i, j in zip(zc[:3], zc[1:4])])
    ratio = float(np.exp(np.mean(np.log(peaks[1:] / peaks[:-1]))))  # per half cycle: exp(-pi zeta / sqrt(1-zeta^2))
    zeta = -np.log(ratio) / np.sqrt(np.pi ** 2 + np.log(ratio) ** 2)
    assert f == pytest.approx(f_model, rel=0.06)
    assert zeta == pytest.approx(zeta_model, abs=0.03)
    assert 0.1 < zeta < 0.4  # it rings: a few cycles, as §7.1.3's arm "oscillates briefly before settling"


def test_the_joint_gives_under_load_and_the_encoder_sees_only_the_servos_part():
    """Add 100 kg to the bucket with the set-points held: the links sag by the torque's change over
    k_eff = kp / 2, the encoders by it over kp (c = 1: they miss half the give)."""
    sim = resting(scene(0.3, 1.0))
    before_q, before_enc = sim.data.qpos[sim.index.qpos].copy(), sim.joint_angles()
    tau0 = sim.data.actuator_force[sim.index.actuator].copy()
    sim.model.body_mass[sim.index.bucket_body] += 100.0
    for _ in range(300):
        sim.step(np.zeros(6))
    dq = sim.data.qpos[sim.index.qpos] - before_q
    denc = sim.joint_angles() - before_enc
    dtau = sim.data.actuator_force[sim.index.actuator] - tau0
    kp = Simulation().model.actuator_gainprm[sim.index.actuator, 0]
    for k in (1, 2, 3):
        assert abs(dq[k]) > 1e-4  # it gives
        assert dq[k] == pytest.approx(-2.0 * dtau[k] / kp[k], rel=0.02)  # the link: tau = k_eff (sp - q)
        assert denc[k] == pytest.approx(-dtau[k] / kp[k], rel=0.02)  # the encoder: q + c tau / kp
    obs = sim.observe()
    np.testing.assert_array_equal(obs.q, sim.joint_angles())  # what the mind reads is the encoders


def test_the_testbed_scene_turns_both_terms_on_and_bad_values_are_refused_by_name():
    t = load_config(CONFIGS_DIR / "scene_testbed.yaml", SceneConfig).truth
    assert t.arm_damping_ratio == 0.3 and t.arm_give_share == 1.0
    for field, bad in (("arm_damping_ratio", 0.0), ("arm_damping_ratio", 3.0), ("arm_give_share", -1.0)):
        with pytest.raises(ValidationError, match=field):
            load_scene_config().truth.model_validate({field: bad})
