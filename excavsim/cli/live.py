"""``--live [ADDRESS]`` as the commands take it: the viewer to stream to, for as long as a command runs.

The recorder's package is imported only when ``--live`` is given (the command line stays light); a viewer
window that ``--live`` alone spawns belongs to the ``with`` block (:func:`excavsim.record.live.live_address`).
"""

from __future__ import annotations

import contextlib


def live_viewer(live: str | None) -> contextlib.AbstractContextManager[str | None]:
    """The address to stream to (None without ``--live``), a spawned window owned by the ``with`` block."""
    if live is None:
        return contextlib.nullcontext(None)
    from excavsim.record.live import live_address

    return live_address(live)


def live_stream(live: str | None) -> contextlib.AbstractContextManager[str | None]:
    """As :func:`live_viewer`, the viewer's gRPC URL (checked: something listens there) for a recorder."""
    if live is None:
        return contextlib.nullcontext(None)
    from excavsim.record.live import live_url

    return live_url(live)
