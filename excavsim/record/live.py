"""Live viewing: where an episode streams to (``excavsim trench --live [ADDRESS]``, ``campaign --live``).

A viewer is either spawned here (it needs a display) or one already running is named by its address;
either way the address is checked before the episode starts, so that a headless machine gets a clear
error at once instead of an episode streaming to nobody.

Who ends which viewer: a viewer the user runs (``rerun``) and names by its address is theirs, and
nothing here ends it; it may outlive any number of commands. A viewer spawned here (``--live`` alone)
belongs to the command that asked for it (:func:`live_address`, :class:`LiveViewer`): when the episode
ends well, the window stays open for its user to look at the end, and the command waits until they
close it (a Ctrl-C closes it too); an error or a Ctrl-C during the episode closes it at once, and so
does the end of the command's process, however it ends (an :class:`~excavsim.processes.OwnedProcess`).
A spawned viewer never outlives its command.
"""

from __future__ import annotations

import atexit
import contextlib
import pathlib
import re
import socket
import subprocess
import time
from collections.abc import Callable, Iterator

from excavsim.errors import ConfigError, DependencyError, UsageError, shorten
from excavsim.processes import OwnedProcess
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
    """The gRPC URL to stream an episode to: the running viewer at ``address``, checked to listen, or
    (``address`` None) a viewer window spawned now by :func:`spawn_viewer`.

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
    """Start a viewer window owned by this Python process and return its gRPC URL: the window closes
    when the process ends, however it ends. Commands use :func:`live_address` instead, which keeps the
    window open after the episode until its user closes it.

    Raises:
        ExcavsimError: as :class:`LiveViewer` does.
    """
    viewer = LiveViewer().start()
    atexit.register(viewer.close)
    return viewer.url


@contextlib.contextmanager
def live_address(live: str | None, *, say: Callable[[str], None] = print) -> Iterator[str | None]:
    """``--live [ADDRESS]`` as a command takes it, for as long as the command runs: None (no ``--live``)
    stays None; an address stays itself (a viewer the user runs, never ended here); ``""`` (``--live``
    alone) becomes the URL of a viewer window spawned now and owned by the ``with`` block (a
    :class:`LiveViewer`: at a good end the block waits until its user closes the window).

    Raises:
        ExcavsimError: as :class:`LiveViewer` does.
    """
    if live != "":
        yield live
        return
    with LiveViewer(say=say) as viewer:
        yield viewer.url


@contextlib.contextmanager
def live_url(live: str | None, *, say: Callable[[str], None] = print) -> Iterator[str | None]:
    """As :func:`live_address`, the viewer's gRPC URL a recorder streams to (an address is checked: something
    must listen there, :func:`viewer_url`)."""
    with live_address(live, say=say) as address:
        yield viewer_url(address) if address is not None else None


class LiveViewer:
    """A Rerun viewer window on a free local port, spawned for ``--live`` and owned by the command that
    asked for it; a context manager.

    Leaving the block after a good end, the command says that the viewer stays open and waits until its
    user closes the window (a Ctrl-C closes it and ends the wait as closing it would): the user asked to
    watch, and the end of the episode is what they came to see. Leaving it on an exception or a Ctrl-C
    closes the window at once, and so does the end of this process, however it ends.

    Args:
        say: where the message about the open window goes.

    Raises:
        ExcavsimError: there is no display (then nothing is started), or the viewer does not listen
            within :data:`SPAWN_TIMEOUT_S`.
    """

    def __init__(self, *, say: Callable[[str], None] = print):
        self.say = say
        self.port = _free_port()
        self.url = f"rerun+http://127.0.0.1:{self.port}/proxy"
        self.command = [*rerun_command(pathlib.Path("x"))[:-1], "--port", str(self.port), "--expect-data-soon"]
        self.proc: OwnedProcess | None = None

    def start(self) -> LiveViewer:
        """Open the window and wait until the viewer listens."""
        if not has_display():
            raise UsageError("--live without an address spawns a viewer window, and there is no display here "
                             "(DISPLAY and WAYLAND_DISPLAY are unset). Run a viewer where there is one (`rerun`) "
                             "and give its address, --live HOST:9876; or record with --record FILE.rrd and use "
                             "`excavsim replay FILE.rrd --screenshot PNG` (headless)")
        try:
            self.proc = OwnedProcess(self.command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        except OSError as exc:
            raise DependencyError(f"cannot start the Rerun viewer ({exc.strerror}): {' '.join(self.command)}") from None
        try:
            deadline = time.monotonic() + SPAWN_TIMEOUT_S
            while not _listening("127.0.0.1", self.port, 0.5):
                if self.proc.poll() is not None:
                    raise DependencyError(f"the Rerun viewer exited with status {self.proc.returncode} before it "
                                          f"listened: {' '.join(self.command)} (run it yourself to see why)")
                if time.monotonic() > deadline:
                    raise DependencyError(f"the Rerun viewer did not listen on port {self.port} in "
                                          f"{SPAWN_TIMEOUT_S:g} s")
                time.sleep(0.2)
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        """Close the window now (and every process the viewer started)."""
        if self.proc is not None:
            self.proc.end()

    def __enter__(self) -> LiveViewer:
        return self.start()

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None and self.proc.poll() is None:
                self.say("the viewer stays open for you to look at the end; close its window to end the command "
                         "(Ctrl-C closes it)")
                with contextlib.suppress(KeyboardInterrupt):
                    self.proc.wait()
        finally:
            self.close()
