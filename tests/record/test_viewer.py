"""The stock Rerun viewer, headless, renders recorded and live episodes (``replay --screenshot``,
``trench --live``). They need Vulkan (a GPU driver or Debian's mesa-vulkan-drivers): on a machine
without a Vulkan driver they skip, naming the apt line, unless EXCAVSIM_REQUIRE_VIEWER is set (as
``.ci/run`` sets it, after installing the package): then they must run. The tests of the viewer's
failure messages need no Vulkan and always run."""

from __future__ import annotations

import glob
import io
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest
from PIL import Image

from excavsim import constants
from excavsim.cli import main
from excavsim.errors import ExcavsimError
from excavsim.loop.scenario import EpisodeSpec, run_spec
from excavsim.record import TrenchRecorder, live
from excavsim.record.geometry import SAND_RGB
from excavsim.record.replay import HeadlessViewer
from tests.children import Watch, descendants, kill

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


def assert_viewer_gone(watch: Watch) -> None:
    """A viewer was started while ``watch`` looked (the guard, the ``rerun`` shim and the viewer it
    runs) and none of them is left running: by pid and start time, not by counting every ``rerun``
    on the machine."""
    assert watch.seen_with("rerun"), f"no viewer process was seen: {sorted(watch.seen.values())}"
    left = watch.left()
    kill(left)
    assert not left, f"left running: {[watch.seen[p] for p in left]}"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("viewer") / "ep.rrd"
    result = run_spec(SPEC, observer=TrenchRecorder(path))
    return path, result


@needs_vulkan
def test_replay_screenshot_renders_the_recording_headless(recording, tmp_path, capsys):
    path, result = recording
    png = tmp_path / "shot.png"
    with Watch() as watch:
        assert main(["replay", str(path), "--screenshot", str(png), "--time", "end", "--size", "1200x750"]) == 0
    assert_viewer_gone(watch)
    assert str(png) in capsys.readouterr().out
    img = np.asarray(Image.open(png).convert("RGB"))
    assert img.shape == (750, 1200, 3)
    assert img.std() > 25, "the screenshot is blank: the viewer rendered nothing"
    world = img[40:int(0.6 * 750), :int(0.6 * 1200)]  # the 3-D view, top left
    assert sand_share(world) > 0.05, "no soil in the 3-D view: the recording's data did not render"


@needs_vulkan
def test_screenshots_at_several_times_get_the_time_in_their_names(recording, tmp_path):
    path, result = recording
    with Watch() as watch:
        assert main(["replay", str(path), "--screenshot", str(tmp_path / "s.png"), "--time", "0", "end",
                     "--size", "640x400"]) == 0
    assert_viewer_gone(watch)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s_0s.png", "s_end.png"]
    first, last = (pixels((tmp_path / n).read_bytes()) for n in ("s_0s.png", "s_end.png"))
    assert np.abs(first.astype(int) - last).mean() > 1  # the time cursor moved: a different picture


@needs_vulkan
def test_a_live_episode_streams_into_a_viewer_with_its_summary(capsys):
    """`trench --live PORT` streams to a running (here headless) viewer; at the end the summary view
    shows the summary (not "(empty)") and the world view shows the soil."""
    with Watch() as watch, HeadlessViewer((1200, 750)) as viewer:
        assert main(["trench", "--goal", "small", "--dig-budget", "1", "--live", str(viewer.port)]) == 0
        assert f"streaming the episode live to {viewer.url}" in capsys.readouterr().out
        state = viewer.client.get_state()
        assert len(state.recordings) == 1
        sim = next(t for t in state.recordings[0].timelines if t.name == "sim_time")
        assert sim.end > 30e9  # the whole episode arrived (37 s simulated)
        views = {v.name: v.view_id for v in viewer.client.get_state().views}
        summary = pixels(viewer.screenshot(sim_time=sim.end / 1e9, view_id=views["summary"]))
        world = pixels(viewer.screenshot(view_id=views["world (true terrain)"]))
    assert_viewer_gone(watch)
    # "(empty)" is one short line; the summary has a title, the end and the per-dig table
    assert text_rows(summary) > 60, f"the summary view shows {text_rows(summary)} rows of text: empty?"
    assert sand_share(world) > 0.05


def test_without_vulkan_the_screenshot_fails_saying_what_to_install(recording, tmp_path, monkeypatch):
    monkeypatch.setenv("VK_ICD_FILENAMES", str(tmp_path / "no-such-driver.json"))  # no Vulkan driver found
    monkeypatch.setenv("WGPU_BACKEND", "vulkan")
    with Watch() as watch, pytest.raises(ExcavsimError, match="mesa-vulkan-drivers"):
        with HeadlessViewer((640, 400), timeout_s=20):
            pass
    assert_viewer_gone(watch)


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


@needs_vulkan
def test_replay_screenshot_as_a_command_leaves_no_viewer_running(recording, tmp_path):
    """``excavsim replay FILE --screenshot PNG`` as a user runs it: when the command has returned, no
    process it started runs (the viewer used to be left behind, orphaned, 340-440 MB each)."""
    path, _ = recording
    png = tmp_path / "shot.png"
    cmd = [sys.executable, "-m", "excavsim.cli", "replay", str(path), "--screenshot", str(png), "--size", "640x400"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=constants.REPO_ROOT)
    with Watch(proc.pid) as watch:
        out, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, out
    assert png.stat().st_size > 0
    assert_viewer_gone(watch)


OWNER = """
import sys, time
from excavsim.record.replay import HeadlessViewer
with HeadlessViewer((640, 400)):
    print("ready", flush=True)
    time.sleep(600)
"""


@needs_vulkan
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_a_headless_viewer_dies_with_the_process_that_started_it(sig):
    """The process that started a viewer is killed while the viewer runs, with no chance to clean up
    (SIGKILL, or SIGTERM's default action): the viewer and its processes go too."""
    owner = subprocess.Popen([sys.executable, "-c", OWNER], stdout=subprocess.PIPE, text=True,
                             cwd=constants.REPO_ROOT, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    try:
        with Watch(owner.pid) as watch:
            assert owner.stdout.readline().strip() == "ready"
        os.kill(owner.pid, sig)
        assert owner.wait(timeout=60) == -sig
        assert_viewer_gone(watch)
    finally:
        kill(descendants(owner.pid))
        if owner.poll() is None:
            owner.kill()
            owner.wait()
        owner.stdout.close()


FAKE_VIEWER = """
import socket, subprocess, sys, time
port = int(sys.argv[sys.argv.index("--port") + 1])
subprocess.Popen(["sleep", "600"])  # a process of its own, as the `rerun` shim runs the real viewer
with socket.create_server(("127.0.0.1", port)) as server:
    while True:
        server.accept()[0].close()
"""


@pytest.fixture()
def fake_window(monkeypatch):
    """``--live`` alone spawns a stand-in for the viewer window (no display needed): a process that
    listens on the viewer's port and starts a child of its own."""
    monkeypatch.setattr(live, "has_display", lambda: True)
    monkeypatch.setattr(live, "rerun_command", lambda path: [sys.executable, "-c", FAKE_VIEWER, str(path)])


def test_a_spawned_live_viewer_closes_at_once_on_an_error(fake_window):
    said = []
    with Watch() as watch, pytest.raises(RuntimeError):
        with live.live_address("", say=said.append) as url:
            assert url.startswith("rerun+http://127.0.0.1:")
            assert live.viewer_url(url) == url  # it listens
            raise RuntimeError("the episode failed")
    assert not said  # no waiting for the user on an error
    assert watch.seen_with("sleep 600")
    left = watch.left()
    kill(left)
    assert not left


def test_a_spawned_live_viewer_stays_open_until_its_user_closes_it(fake_window):
    """At a good end the command says the window stays open and waits; when the user closes it (here:
    the window's process ends) the command ends, with nothing of the viewer left."""
    said = []

    def user_closes_the_window():
        while not (said and (window := [p for p, cmd in list(watch.seen.items()) if "create_server" in cmd])):
            threading.Event().wait(0.05)
        os.kill(window[0][0], signal.SIGTERM)

    with Watch() as watch:
        closer = threading.Thread(target=user_closes_the_window, daemon=True)
        closer.start()
        with live.live_address("", say=said.append) as url:
            assert live.viewer_url(url) == url
        closer.join(timeout=60)
    assert said and "close its window" in said[0]
    left = watch.left()
    kill(left)
    assert not left
    with live.live_address("9876") as address:  # a viewer the user runs: given back, never started or ended
        assert address == "9876"
