"""Open a recording in the Rerun viewer (``excavsim replay``)."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
from collections.abc import Callable

from excavsim.errors import ExcavsimError


def rerun_command(path: str | os.PathLike) -> list[str]:
    """The command that opens ``path`` in the Rerun viewer: the ``rerun`` next to this Python, on the
    PATH, or ``python -m rerun``."""
    here = pathlib.Path(sys.executable).parent / ("rerun.exe" if os.name == "nt" else "rerun")
    exe = str(here) if here.exists() else shutil.which("rerun")
    return [exe, str(path)] if exe else [sys.executable, "-m", "rerun", str(path)]


def has_display() -> bool:
    """Whether a viewer window can open: always on macOS and Windows, with DISPLAY or WAYLAND_DISPLAY on Linux."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def replay(path: str | os.PathLike, *, dry_run: bool = False, say: Callable[[str], None] = print) -> list[str]:
    """Open a recording in the Rerun viewer and wait until it is closed.

    Args:
        path: an ``.rrd`` file written by :class:`RerunRecorder`.
        dry_run: only say the command that would run.
        say: where messages go.

    Returns:
        The viewer command (run, or only said when ``dry_run`` or when there is no display).

    Raises:
        ExcavsimError: the file does not exist, or the viewer exited with an error.
    """
    p = pathlib.Path(path)
    if not p.is_file():
        raise ExcavsimError(f"no recording at {p}: give an .rrd file written by `excavsim trench --record FILE.rrd`")
    cmd = rerun_command(p)
    shown = " ".join(cmd)
    if dry_run:
        say(f"would run: {shown}")
        return cmd
    if not has_display():
        say(f"no display here (DISPLAY and WAYLAND_DISPLAY are unset), so the viewer cannot open. On a machine "
            f"with a display, run:\n  {shown}\nor copy {p} there and open it with `rerun {p.name}`.")
        return cmd
    status = subprocess.run(cmd, check=False).returncode
    if status != 0:
        raise ExcavsimError(f"the Rerun viewer exited with status {status}: {shown}")
    return cmd
