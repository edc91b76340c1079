"""The trenching action's geometry (§3.4): penetrate, drag, curl, the whole path and the soil it sweeps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from excavsim.config import load_planner_config
from excavsim.handoff.goal import SurfaceProfile
from excavsim.planning.action import (curl, curl_radius, drag, padded_distances, penetrate, penetration_samples,
                                      running_total, soil_depth, step_lengths, swept, trajectory)

CFG = load_planner_config()  # epsilon 10 deg, omega 50 deg/m, zeta 8 deg, curl to -30 deg, 2.5 cm samples
FLAT = SurfaceProfile(np.array([0.0, 4.0]), np.array([0.5, 0.5]))  # the box's 0.5 m fill


def test_trajectory_follows_the_rake_rules():
    """§3.4.2: penetrate at rake alpha + epsilon; drag with rake max(zeta, rho_i - omega s); curl up."""
    alpha = math.radians(30)
    poses, phases = trajectory((2.6, alpha, 0.2, 1.0), FLAT, CFG, radius=0.3)
    pen, drg, crl = poses[phases == 0], poses[phases == 1], poses[phases == 2]
    np.testing.assert_allclose(pen[:, 2], alpha + math.radians(10))
    np.testing.assert_allclose(pen[-1, :2], [2.6 - 0.2 * math.cos(alpha), 0.5 - 0.2 * math.sin(alpha)])
    s = pen[-1, 0] - drg[:, 0]
    np.testing.assert_allclose(drg[:, 2], np.maximum(math.radians(8), alpha + math.radians(10) - math.radians(50) * s))
    np.testing.assert_allclose(drg[:, 1], pen[-1, 1])
    # The curl turns about a centre 0.3 m from the edge, between the blade's heel direction and its
    # normal, to -30 deg; the blade's points then move away from the soil below it (Fig. 16).
    rho = drg[-1, 2]
    b, zt = np.array([math.cos(rho), math.sin(rho)]), np.array([-math.sin(rho), math.cos(rho)])
    centre = drg[-1, :2] + 0.3 * (b + zt) / math.sqrt(2)
    np.testing.assert_allclose(np.linalg.norm(crl[:, :2] - centre, axis=1), 0.3, atol=1e-12)
    heel = drg[-1, :2] + 0.2 * b  # a point of the bottom 0.2 m behind the edge (< 0.3 / sqrt 2)
    v = np.array([(heel - centre)[1], -(heel - centre)[0]])  # clockwise rotation at unit rate
    assert v @ zt > 0
    assert crl[-1, 2] == pytest.approx(math.radians(-30))
    assert np.all(np.diff(crl[:, 2]) < 0) and crl[-1, 1] > drg[-1, 1]


def test_the_search_and_one_action_share_the_penetration():
    """The search samples every 2.5 cm padded to the longest d1, the trajectory evenly up to d1: both
    are the same line, ending at the very same pose."""
    k, alpha, d1 = np.array([2.6, 2.4]), np.radians([30.0, 45.0]), np.array([0.06, 0.1])
    s = padded_distances(d1, 0.025, 6)
    np.testing.assert_allclose(s, [[0, 0.025, 0.05, 0.06, 0.06, 0.06], [0, 0.025, 0.05, 0.075, 0.1, 0.1]])
    pen = penetrate(k, alpha, s, FLAT, CFG)
    assert pen.shape == (2, 6, 3)
    np.testing.assert_array_equal(pen[0, 3:], np.repeat(pen[0, 3:4], 3, axis=0))  # padding repeats the end
    for i in range(2):
        poses, phases = trajectory((k[i], alpha[i], d1[i], 0.0), FLAT, CFG, radius=0.4)
        path = poses[phases == 0]
        assert len(path) == penetration_samples(d1[i], 0.025) == (4, 5)[i]
        np.testing.assert_array_equal(path[-1], pen[i, -1])
        along = np.hypot(path[:, 0] - k[i], path[:, 1] - 0.5)
        np.testing.assert_allclose(along, np.linspace(0.0, d1[i], len(path)), atol=1e-15)


def test_the_drag_rake_falls_by_omega_per_metre_down_to_zeta():
    start = np.array([[2.5, 0.3, math.radians(40.0)]])
    poses = drag(start, np.arange(50) * 0.025, CFG)[0]
    np.testing.assert_allclose(poses[:, 0], 2.5 - np.arange(50) * 0.025)
    assert np.all(poses[:, 1] == 0.3)
    rake = np.degrees(poses[:, 2])
    np.testing.assert_allclose(rake[:5], 40.0 - 50.0 * np.arange(5) * 0.025)
    assert rake.min() == pytest.approx(8.0) and np.all(np.diff(rake) <= 1e-12)
    assert rake[int(32 / 50 / 0.025) + 1] == pytest.approx(8.0)  # 32 deg lost after 0.64 m


def test_the_curl_radius_is_the_smallest_whose_end_pose_is_reachable():
    """Fig. 23: the radii are tried from the smallest; the first reachable end pose decides."""
    start = np.array([[2.2, 0.3, 0.3], [2.0, 0.25, 0.2]])
    ends = {r: curl(start, np.full(2, r), CFG)[:, -1] for r in CFG.curl_radii_m}
    wanted = [0.5, 0.8]  # start 0 reaches its end pose from 0.5 m on, start 1 only at 0.8 m
    accept = [ends[r][i] for i in range(2) for r in CFG.curl_radii_m if r >= wanted[i]]

    def reachable(poses):  # (m, 1, 3) end poses -> (m, 1)
        return np.array([[any(np.allclose(p, q, rtol=0, atol=1e-12) for q in accept)] for p in poses[:, 0]])

    np.testing.assert_array_equal(curl_radius(start, CFG, reachable), wanted)
    np.testing.assert_array_equal(curl_radius(start, CFG, lambda poses: np.ones(poses.shape[:-1], bool)), 0.35)
    radius = curl_radius(start, CFG, lambda poses: np.zeros(poses.shape[:-1], bool), default=0.35)
    np.testing.assert_array_equal(radius, 0.35)
    assert np.isnan(curl_radius(start, CFG, lambda poses: np.zeros(poses.shape[:-1], bool))).all()


def test_a_flat_cut_sweeps_depth_times_length_times_width():
    x = np.linspace(2.6, 2.0, 25)
    path = np.stack([x, np.full_like(x, 0.4), np.full_like(x, 0.3)], axis=-1)
    steps = swept(path, FLAT, 0.3)
    np.testing.assert_allclose(steps.sum(), 0.1 * 0.6 * 0.3, rtol=1e-12)
    total = running_total(steps)
    assert total[0] == 0.0 and total[-1] == pytest.approx(0.018, rel=1e-12) and np.all(np.diff(total) >= 0)
    np.testing.assert_allclose(soil_depth(path, FLAT), 0.1)
    np.testing.assert_allclose(step_lengths(path), 0.025)
    above = path + np.array([0.0, 0.2, 0.0])  # 10 cm above the surface: no soil, no depth
    assert swept(above, FLAT, 0.3).sum() == 0.0 and np.all(soil_depth(above, FLAT) == 0.0)
