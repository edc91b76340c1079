"""Live viewing: where an episode streams to (``excavsim trench --live [ADDRESS]``, ``campaign --live``).

A viewer is either spawned here (it needs a display) or one already running is named by its address;
either way the address is checked before the episode starts, so that a headless machine gets a clear
error at once instead of an episode streaming to nobody.
"""

from __future__ import annotations

import pathlib
import re
import socket

from excavsim.errors import ConfigError, DependencyError, UsageError, shorten
from excavsim.record.replay import _free_port, has_display, rerun_command

DEFAULT_PORT = 9876  # where `rerun` listens when started without options
CONNECT_TIMEOUT_S = 3.0  # how long a named viewer may take to accept a connection [s]
SPAWN_TIMEOUT_S = 30.0  # how long a spawned viewer may take to listen [s]


def parse_address(address: str) -> tuple[str, int, str]:
    """(host, port, gRPC URL) of a viewer address: ``PORT``, ``HOST:PORT``, ``HOST`` (port 9876) or a
    ``rerun+http://HOST:PORT/proxy`` URL (also ``rerun://``, ``rerun+https://``).

    Raises:
        ExcavsimError: the address is none of these.
    """
    text = address.strip()
    m = re.fullmatch(r"(rerun(?:\+https?)?)://([^/:]+|\[[^\]]+\])(?::(\d+))?(/proxy)?/?", text)
    if m:
        scheme, host, port = m.group(1), m.group(2), int(m.group(3) or DEFAULT_PORT)
    else:
        m = re.fullmatch(r"(?:([A-Za-z0-9._-]+|\[[0-9A-Fa-f:]+\]):)?(\d+)|([A-Za-z0-9._-]*[A-Za-z_-][A-Za-z0-9._-]*)",
                         text)
        if not m:
            raise ConfigError(f"--live {shorten(repr(address), 100)}: not a viewer address; give PORT, HOST:PORT or "
                              "rerun+http://HOST:PORT/proxy (a viewer started with `rerun` listens on 9876)")
        scheme = "rerun+http"
        host = m.group(3) or m.group(1) or "127.0.0.1"
        port = int(m.group(2)) if m.group(2) else DEFAULT_PORT
    if not 0 < port < 65536:
        raise ConfigError(f"--live {shorten(repr(address), 100)}: port {port} is out of range (1 to 65535)")
    return host.strip("[]"), port, f"{scheme}://{host}:{port}/proxy"


def _listening(host: str, port: int, timeout_s: float) -> bool:
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return True
    except OSError:
        return False


def viewer_url(address: str | None) -> str:
    """The gRPC URL to stream an episode to: a viewer spawned now (``address`` None) or the running
    one at ``address``, checked to listen.

    Raises:
        ExcavsimError: no display to spawn a viewer on (a headless machine), the viewer did not start,
            or nothing listens at ``address``.
    """
    if address is None:
        return spawn_viewer()
    host, port, url = parse_address(address)
    if not _listening(host, port, CONNECT_TIMEOUT_S):
        raise DependencyError(f"--live {shorten(address, 100)}: no Rerun viewer listens at {host}:{port}. Start "
                              f"one there with `rerun --port {port}` (or `rerun --serve-web` for a browser), or "
                              "record to a file with --record FILE.rrd and replay it later")
    return url


def spawn_viewer() -> str:
    """Start a Rerun viewer window on a free local port and return its gRPC URL.

    Raises:
        ExcavsimError: there is no display (then nothing is started), or the viewer does not listen
            within :data:`SPAWN_TIMEOUT_S`.
    """
    import subprocess
    import time

    if not has_display():
        raise UsageError("--live without an address spawns a viewer window, and there is no display here "
                         "(DISPLAY and WAYLAND_DISPLAY are unset). Run a viewer where there is one (`rerun`) "
                         "and give its address, --live HOST:9876; or record with --record FILE.rrd and use "
                         "`excavsim replay FILE.rrd --screenshot PNG` (headless)")
    port = _free_port()
    command = [*rerun_command(pathlib.Path("x"))[:-1], "--port", str(port), "--expect-data-soon"]
    try:
        proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, start_new_session=True)  # outlives the episode
    except OSError as exc:
        raise DependencyError(f"cannot start the Rerun viewer ({exc.strerror}): {' '.join(command)}") from None
    deadline = time.monotonic() + SPAWN_TIMEOUT_S
    while not _listening("127.0.0.1", port, 0.5):
        if proc.poll() is not None:
            raise DependencyError(f"the Rerun viewer exited with status {proc.returncode} before it listened: "
                                  f"{' '.join(command)} (run it yourself to see why)")
        if time.monotonic() > deadline:
            proc.terminate()
            raise DependencyError(f"the Rerun viewer did not listen on port {port} in {SPAWN_TIMEOUT_S:g} s")
        time.sleep(0.2)
    return f"rerun+http://127.0.0.1:{port}/proxy"


class LiveRecorders:
    """The campaign recorder factory of ``campaign --live``: every episode is recorded to its file, and
    the one whose id is ``episode`` also streams to the viewer at ``url``. Picklable (it travels to
    the worker processes)."""

    def __init__(self, url: str, episode: str):
        self.url, self.episode = url, episode

    def __call__(self, path: pathlib.Path):
        from excavsim.record.recorder import RerunRecorder

        return RerunRecorder(path, live=self.url if pathlib.Path(path).stem == self.episode else None)
