"""Open a recording in the Rerun viewer (``excavsim replay``).

Every viewer started here is an :class:`~excavsim.processes.OwnedProcess`: it ends when the command
that started it ends, on success, on an error, on Ctrl-C and when the command is killed (the window of
``excavsim replay FILE`` when its user closes it, or with the command).
"""

from __future__ import annotations

import os
import pathlib
import re
import shutil
import subprocess
import sys
from collections.abc import Callable

from excavsim.errors import ConfigError, DataFileError, DependencyError, ExcavsimError, shorten
from excavsim.processes import OwnedProcess


def rerun_command(path: str | os.PathLike) -> list[str]:
    """The command that opens ``path`` in the Rerun viewer: the ``rerun`` next to this Python, on the
    PATH, or ``python -m rerun``."""
    here = pathlib.Path(sys.executable).parent / ("rerun.exe" if os.name == "nt" else "rerun")
    exe = str(here) if here.exists() else shutil.which("rerun")
    return [exe, str(path)] if exe else [sys.executable, "-m", "rerun", str(path)]


RRD_MAGIC = b"RRF2"  # the first bytes of a Rerun 0.2x+ recording
VERIFY_TIMEOUT_S = 300  # the longest `rerun rrd verify` may take before replay gives up [s]


def check_recording(path: str, *, warn: Callable[[str], None] | None = None) -> None:
    """Refuse ``path`` unless it is a Rerun recording the installed Rerun can load (``rerun rrd verify``).

    A recording cut short (an episode killed before it closed its file) has no footer: it is
    accepted with a warning, since the viewer shows what it holds.

    Args:
        path: the file.
        warn: where the warning about a cut-short recording goes (default stderr).

    Raises:
        ExcavsimError: naming the file and what is wrong with it.
    """
    shown = shorten(path, 200)
    try:
        if not os.path.isfile(path):
            raise DataFileError(f"no recording at {shown}: give an .rrd file written by `excavsim trench --record "
                                "FILE.rrd`")
        with open(path, "rb") as f:
            head = f.read(len(RRD_MAGIC))
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or exc
        raise DataFileError(f"{shown}: cannot read the recording ({why}); give an .rrd file written by "
                            "`excavsim trench --record FILE.rrd`") from None
    if head != RRD_MAGIC:
        raise DataFileError(f"{shown}: not a Rerun recording (it does not start with {RRD_MAGIC.decode()}); give an "
                            ".rrd file written by `excavsim trench --record FILE.rrd`")
    verify = [*rerun_command(path)[:-1], "rrd", "verify"]
    for footers in ("true", "false"):
        try:
            with OwnedProcess([*verify, "--check-footers", footers, path], stdin=subprocess.DEVNULL,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace") as proc:
                try:
                    out, err = proc.communicate(timeout=VERIFY_TIMEOUT_S)
                except subprocess.TimeoutExpired:
                    raise ExcavsimError(f"{shown}: `rerun rrd verify` did not finish in {VERIFY_TIMEOUT_S} s") from None
        except OSError as exc:
            raise DependencyError(f"{shown}: cannot run `rerun rrd verify` ({exc.strerror})") from None
        verified = re.search(r"(\d+) files? verified", out + err)
        if proc.returncode == 0 and verified and int(verified.group(1)) == 0:
            raise DataFileError(f"{shown}: a Rerun header and no recording in it (`rerun rrd verify` found nothing "
                                "to verify); give an .rrd file written by `excavsim trench --record FILE.rrd`")
        if proc.returncode == 0:
            if footers == "false":
                (warn or _stderr)(f"excavsim: warning: {shown} has no footer (the recording was cut short); "
                                  "replaying what it holds")
            return
    lines = [ln for ln in err.splitlines() if ln.strip()]
    raise DataFileError(f"{shown}: Rerun cannot load this recording: {shorten(lines[-1] if lines else out, 200)}")


def _stderr(text: str) -> None:
    print(text, file=sys.stderr)


def has_display() -> bool:
    """Whether a viewer window can open: always on macOS and Windows, with DISPLAY or WAYLAND_DISPLAY on Linux."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def replay(path: str | os.PathLike, *, dry_run: bool = False, say: Callable[[str], None] = print) -> list[str]:
    """Open a recording in the Rerun viewer and wait until it is closed (a Ctrl-C, an error or the end
    of this process closes it too).

    Args:
        path: an ``.rrd`` file written by :class:`TrenchRecorder`.
        dry_run: only say the command that would run.
        say: where messages go.

    Returns:
        The viewer command (run, or only said when ``dry_run`` or when there is no display).

    Raises:
        ExcavsimError: the file does not exist, or the viewer exited with an error.
    """
    p = pathlib.Path(path)
    if not p.is_file():
        raise DataFileError(f"no recording at {p}: give an .rrd file written by `excavsim trench --record FILE.rrd`")
    cmd = rerun_command(p)
    shown = " ".join(cmd)
    if dry_run:
        say(f"would run: {shown}")
        return cmd
    if not has_display():
        say(f"no display here (DISPLAY and WAYLAND_DISPLAY are unset), so the viewer cannot open. On a machine "
            f"with a display, run:\n  {shown}\nor copy {p} there and open it with `rerun {p.name}`.")
        return cmd
    try:
        with OwnedProcess(cmd, stdin=subprocess.DEVNULL) as viewer:
            status = viewer.wait()
    except OSError as exc:
        raise DependencyError(f"cannot start the Rerun viewer ({exc.strerror}): {shown}") from None
    if status != 0:
        raise ExcavsimError(f"the Rerun viewer exited with status {status}: {shown}")
    return cmd


VULKAN_PACKAGE = "mesa-vulkan-drivers"  # Debian/Ubuntu: Vulkan software rendering (llvmpipe) for the headless viewer
VIEWER_START_S = 60.0  # the longest the headless viewer may take to answer [s]
SETTLE_TRIES = 6  # screenshots taken at one time until two in a row are the same (the data has arrived)


def _free_port() -> int:
    """A TCP port nobody listens on now (the viewer binds it a moment later)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _no_vulkan(output: str) -> bool:
    """Whether the viewer's output says it found no graphics adapter (it panics then, e.g. "Failed to get
    render context" after falling back to GL, or "No graphics adapter was found")."""
    low = output.lower()
    return any(w in low for w in ("render context", "graphics adapter", "no suitable adapter", "wgpu adapter"))


def _viewer_trouble(output: str) -> str:
    """The lines of the viewer's output that say what went wrong: its panic, else its last lines."""
    lines = [re.sub(r"\x1b\[[0-9;]*m", "", ln).rstrip() for ln in output.splitlines()]
    lines = [ln for ln in lines if ln.strip()]
    for i, ln in enumerate(lines):
        if "panicked" in ln:
            return "\n".join(lines[i:i + 2])
    return "\n".join(lines[-4:])


class HeadlessViewer:
    """The stock Rerun viewer, headless (``rerun --headless``), on a free local port, driven through
    :class:`rerun.experimental.ViewerClient`; a context manager that ends the viewer it started, with
    every process the viewer started, when the block is left (on success, an error or Ctrl-C) or this
    process dies (an :class:`~excavsim.processes.OwnedProcess`).

    Needs Vulkan: a GPU driver or Mesa's software rasterizer (Debian/Ubuntu: ``apt-get install
    mesa-vulkan-drivers``).

    Args:
        size: the viewer's window size (width, height) [logical points].
        timeout_s: how long the viewer may take to start and answer.

    Raises:
        ExcavsimError: the viewer cannot run (no ``rerun`` executable, no Vulkan adapter, no answer).
    """

    def __init__(self, size: tuple[int, int] = (1600, 1000), *, timeout_s: float = VIEWER_START_S):
        import tempfile

        self.size, self.timeout_s = size, timeout_s
        self.port = _free_port()
        self.url = f"rerun+http://127.0.0.1:{self.port}/proxy"
        self.command = [*rerun_command("x")[:-1], "--headless", "--window-size", f"{size[0]}x{size[1]}",
                        "--port", str(self.port), "--hide-welcome-screen", "--memory-limit", "2GB"]
        self._log = tempfile.TemporaryFile()
        self.proc: OwnedProcess | None = None
        self.client = None

    def __enter__(self) -> HeadlessViewer:
        import time

        import rerun.experimental as rrx

        try:
            self.proc = OwnedProcess(self.command, stdin=subprocess.DEVNULL, stdout=self._log,
                                     stderr=subprocess.STDOUT)
        except OSError as exc:
            raise DependencyError(f"cannot start the Rerun viewer ({exc.strerror}): {' '.join(self.command)}; "
                                  "reinstall excavsim (rerun-sdk installs the `rerun` command)") from None
        deadline = time.monotonic() + self.timeout_s
        try:
            while True:
                if self.proc.poll() is not None:
                    raise self._failure(f"the headless Rerun viewer exited with status {self.proc.returncode}")
                try:
                    client = rrx.ViewerClient.connect(self.url)
                    client.get_state()
                    self.client = client
                    return self
                except Exception:  # not listening yet  # noqa: BLE001
                    if time.monotonic() > deadline:
                        raise self._failure(f"the headless Rerun viewer did not answer in {self.timeout_s:g} s")
                    time.sleep(0.3)
        except BaseException:
            self.close()
            raise

    def __exit__(self, *exc) -> None:
        self.close()

    def output(self) -> str:
        """What the viewer printed so far."""
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def _failure(self, what: str) -> DependencyError:
        out = self.output()
        tail = _viewer_trouble(out)
        hint = (f" It found no Vulkan graphics adapter: install a Vulkan driver; without a GPU, Mesa's software "
                f"rasterizer does (Debian/Ubuntu: `apt-get install {VULKAN_PACKAGE}`)." if _no_vulkan(out) else "")
        return DependencyError(f"{what}.{hint}\nviewer command: {' '.join(self.command)}"
                               + (f"\nviewer output:\n{tail}" if tail else ""))

    def close(self) -> None:
        """End the viewer and the processes it started (if this object started it)."""
        try:
            if self.proc is not None:
                self.proc.end()
        finally:
            self._log.close()

    def open(self, path: str | os.PathLike, *, timeout_s: float = 60.0):
        """Open a recording and wait until it has loaded; returns its :class:`rerun.experimental.Recording`."""
        import time

        self.client.open(str(pathlib.Path(path).resolve()))
        deadline = time.monotonic() + timeout_s
        while True:
            state = self.client.get_state()
            if state.recordings and not state.loading:
                return next(r for r in state.recordings if r.store_id == state.active_recording)
            if time.monotonic() > deadline:
                raise self._failure(f"the viewer did not load {path} in {timeout_s:g} s")
            time.sleep(0.3)

    def screenshot(self, out: str | os.PathLike | None = None, *, sim_time: float | None = None,
                   view_id: str | None = None) -> bytes:
        """A PNG of the whole viewer, or of one view, at ``sim_time`` [s] (None: where the cursor is);
        written to ``out`` when given, and returned.

        The viewer fetches the chunks a time needs when the cursor gets there, so screenshots are
        taken until two in a row are the same (at most :data:`SETTLE_TRIES`)."""
        import time

        if sim_time is not None:
            self.client.set_time("sim_time", duration=float(sim_time), play_state="paused")
        last = None
        for _ in range(SETTLE_TRIES):
            png = self.client.take_screenshot(view_id)
            if png == last:
                break
            last = png
            time.sleep(0.5)
        if out is not None:
            pathlib.Path(out).write_bytes(png)
        return png


def screenshots(path: str | os.PathLike, shots: list[tuple[float | None, str | os.PathLike]], *,
                size: tuple[int, int] = (1600, 1000), say: Callable[[str], None] = print) -> list[pathlib.Path]:
    """Render a recording in the headless viewer and write a screenshot at each simulated time.

    Args:
        path: an ``.rrd`` file.
        shots: (time [s] on ``sim_time``, or None for the end of the recording; PNG path) pairs.
        size: the viewer's size (width, height).
        say: where messages go.

    Returns:
        The PNGs written.

    Raises:
        ExcavsimError: the viewer cannot run or load the file, or a time lies outside the recording.
    """
    start, end = sim_time_span(path)
    for t, _ in shots:  # before the viewer starts
        if t is not None and not start - 1e-9 <= t <= end + 1e-9:
            raise ConfigError(f"--time {t:g}: the recording spans {start:g} to {end:g} s of simulated time")
    written = []
    with HeadlessViewer(size) as viewer:
        viewer.open(path)
        for t, out in shots:
            t = end if t is None else t
            out = pathlib.Path(out)
            out.parent.mkdir(parents=True, exist_ok=True)
            viewer.screenshot(out, sim_time=t)
            say(f"screenshot at {t:g} s simulated: {out}")
            written.append(out)
    return written


def sim_time_span(path: str | os.PathLike) -> tuple[float, float]:
    """The first and last time [s] on a recording's ``sim_time`` timeline.

    Raises:
        ExcavsimError: the recording has no ``sim_time`` timeline (not an excavsim recording).
    """
    import pyarrow as pa
    from rerun.chunk import RrdReader

    lo, hi = float("inf"), float("-inf")
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static or "sim_time" not in chunk.timeline_names:
            continue
        times = chunk.to_record_batch().column("sim_time").cast(pa.int64()).to_numpy(zero_copy_only=False)
        if times.size:
            lo, hi = min(lo, times.min() / 1e9), max(hi, times.max() / 1e9)
    if lo > hi:
        raise DataFileError(f"{path} has no sim_time timeline: not a recording of `excavsim trench --record`")
    return float(lo), float(hi)


def log_entries(path: str | os.PathLike) -> list[tuple[float, str]]:
    """The ``/log`` lines of a recording: (sim_time [s], text), in time order (e.g. to find when each
    dig ended, for screenshots)."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    found = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != "/log" or chunk.is_static or "sim_time" not in chunk.timeline_names:
            continue
        batch = chunk.to_record_batch()
        times = batch.column("sim_time").cast(pa.int64()).to_pylist()
        texts = batch.column("TextLog:text").to_pylist()
        found += [(t / 1e9, text[0]) for t, text in zip(times, texts) if text]
    return sorted(found, key=lambda e: e[0])
