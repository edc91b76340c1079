"""The stock Rerun viewer, headless, renders recorded and live episodes (``replay --screenshot``,
``trench --live``). They need Vulkan (a GPU driver or Debian's mesa-vulkan-drivers): on a machine
without a Vulkan driver they skip, naming the apt line, unless EXCAVSIM_REQUIRE_VIEWER is set (as
``.ci/run`` sets it, after installing the package): then they must run. The tests of the viewer's
failure messages need no Vulkan and always run."""

from __future__ import annotations

import glob
import io
import os

import numpy as np
import pytest
from PIL import Image

from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.loop.scenario import EpisodeSpec, run_spec
from excavsim.record import TrenchRecorder
from excavsim.record.geometry import SAND_RGB
from excavsim.record.replay import HeadlessViewer

ICD_DIRS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d")


def vulkan_driver() -> str | None:
    """A Vulkan driver's manifest the loader would find (the variables that name one, else the standard
    folders), or None."""
    for var in ("VK_DRIVER_FILES", "VK_ICD_FILENAMES"):
        named = [f for f in os.environ.get(var, "").split(os.pathsep) if f and os.path.exists(f)]
        if named:
            return named[0]
    found = [f for d in ICD_DIRS for f in sorted(glob.glob(os.path.join(d, "*.json")))]
    return found[0] if found else None


NO_VULKAN = ("no Vulkan driver (the headless Rerun viewer needs one): "
             "sudo apt-get install mesa-vulkan-drivers  (CI sets EXCAVSIM_REQUIRE_VIEWER=1 and runs these)")
needs_vulkan = pytest.mark.skipif(vulkan_driver() is None and not os.environ.get("EXCAVSIM_REQUIRE_VIEWER"),
                                  reason=NO_VULKAN)

SPEC = EpisodeSpec(
    name="viewed", goal="small", dig_budget=1,
    sensing={"map": {"n_scans": 1}, "scanner": {"n_azimuth": 60, "n_elevation": 60}},
    planner={"grid": {"k_min_m": 1.8, "k_max_m": 2.6, "k_step_m": 0.2, "alpha_step_deg": 15.0, "d1_step_m": 0.04}})


def pixels(png: bytes) -> np.ndarray:
    """(H, W, 3) uint8 of a PNG."""
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def sand_share(img: np.ndarray) -> float:
    """The share of pixels of the sand's colour, lit or shaded (its hue: red > green > blue, warm)."""
    rgb = img.astype(float)
    hue = SAND_RGB / SAND_RGB.max()
    scale = rgb.max(axis=-1, keepdims=True)
    near = np.abs(rgb / np.maximum(scale, 1) - hue).max(axis=-1) < 0.08
    return float((near & (scale[..., 0] > 60)).mean())


def text_rows(img: np.ndarray) -> int:
    """How many pixel rows hold light text on the viewer's dark background."""
    return int(((img.min(axis=-1) > 150).sum(axis=1) > 2).sum())


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("viewer") / "ep.rrd"
    result = run_spec(SPEC, observer=TrenchRecorder(path))
    return path, result


@needs_vulkan
def test_replay_screenshot_renders_the_recording_headless(recording, tmp_path, capsys):
    path, result = recording
    png = tmp_path / "shot.png"
    assert main(["replay", str(path), "--screenshot", str(png), "--time", "end", "--size", "1200x750"]) == 0
    assert str(png) in capsys.readouterr().out
    img = np.asarray(Image.open(png).convert("RGB"))
    assert img.shape == (750, 1200, 3)
    assert img.std() > 25, "the screenshot is blank: the viewer rendered nothing"
    world = img[40:int(0.6 * 750), :int(0.6 * 1200)]  # the 3-D view, top left
    assert sand_share(world) > 0.05, "no soil in the 3-D view: the recording's data did not render"


@needs_vulkan
def test_screenshots_at_several_times_get_the_time_in_their_names(recording, tmp_path):
    path, result = recording
    assert main(["replay", str(path), "--screenshot", str(tmp_path / "s.png"), "--time", "0", "end",
                 "--size", "640x400"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s_0s.png", "s_end.png"]
    first, last = (pixels((tmp_path / n).read_bytes()) for n in ("s_0s.png", "s_end.png"))
    assert np.abs(first.astype(int) - last).mean() > 1  # the time cursor moved: a different picture


@needs_vulkan
def test_a_live_episode_streams_into_a_viewer_with_its_summary(capsys):
    """`trench --live PORT` streams to a running (here headless) viewer; at the end the summary view
    shows the summary (not "(empty)") and the world view shows the soil."""
    with HeadlessViewer((1200, 750)) as viewer:
        assert main(["trench", "--goal", "small", "--dig-budget", "1", "--live", str(viewer.port)]) == 0
        assert f"streaming the episode live to {viewer.url}" in capsys.readouterr().out
        state = viewer.client.get_state()
        assert len(state.recordings) == 1
        sim = next(t for t in state.recordings[0].timelines if t.name == "sim_time")
        assert sim.end > 30e9  # the whole episode arrived (37 s simulated)
        views = {v.name: v.view_id for v in viewer.client.get_state().views}
        summary = pixels(viewer.screenshot(sim_time=sim.end / 1e9, view_id=views["summary"]))
        world = pixels(viewer.screenshot(view_id=views["world (true terrain)"]))
    # "(empty)" is one short line; the summary has a title, the end and the per-dig table
    assert text_rows(summary) > 60, f"the summary view shows {text_rows(summary)} rows of text: empty?"
    assert sand_share(world) > 0.05


def test_without_vulkan_the_screenshot_fails_saying_what_to_install(recording, tmp_path, monkeypatch):
    monkeypatch.setenv("VK_ICD_FILENAMES", str(tmp_path / "no-such-driver.json"))  # no Vulkan driver found
    monkeypatch.setenv("WGPU_BACKEND", "vulkan")
    with pytest.raises(ExcavsimError, match="mesa-vulkan-drivers"):
        with HeadlessViewer((640, 400), timeout_s=20):
            pass


def test_replay_refuses_a_time_outside_the_recording_before_starting_a_viewer(recording, tmp_path, capsys):
    path, result = recording
    assert main(["replay", str(path), "--screenshot", str(tmp_path / "x.png"), "--time", "1e6"]) == 2
    assert "the recording spans 0 to" in capsys.readouterr().err
    for bad in (["--time", "-1"], ["--time", "soon"], ["--size", "99x99"], ["--size", "wide"]):
        assert main(["replay", str(path), "--screenshot", str(tmp_path / "x.png"), *bad]) == 2
    assert main(["replay", str(path), "--time", "3"]) == 2  # --time without --screenshot
    assert "go with --screenshot" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_live_fails_at_once_when_no_viewer_can_be_reached(monkeypatch, capsys):
    assert main(["trench", "--dig-budget", "1", "--live", "127.0.0.1:1"]) == 2
    assert "no Rerun viewer listens at 127.0.0.1:1" in capsys.readouterr().err
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main(["trench", "--dig-budget", "1", "--live"]) == 2
    assert "no display here" in capsys.readouterr().err
    assert main(["trench", "--dig-budget", "1", "--live", "rerun+ftp://x"]) == 2
    assert "not a viewer address" in capsys.readouterr().err
