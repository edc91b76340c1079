"""The processes a test started, found in /proc (Linux): to check that none of them is left running.

A process is known by its pid and its start time (a pid alone may be reused by an unrelated process
once the first one is gone). :class:`Watch` records every process below a pid while a block runs,
since a process orphaned by its parent is no longer below it when the test looks afterwards.
"""

from __future__ import annotations

import os
import pathlib
import signal
import threading
import time

Proc = tuple[int, int]  # (pid, start time in clock ticks since boot)


def _stat(pid: int) -> tuple[str, int, int, int] | None:
    """(state, parent pid, process group, start time) of ``pid``, or None when it does not exist."""
    try:
        fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return None
    return fields[0], int(fields[1]), int(fields[2]), int(fields[19])


def _live() -> dict[int, tuple[str, int, int, int]]:
    """Every process that runs now (zombies left out), by pid."""
    out = {}
    for entry in pathlib.Path("/proc").iterdir():
        if entry.name.isdigit():
            st = _stat(int(entry.name))
            if st is not None and st[0] not in ("Z", "X"):
                out[int(entry.name)] = st
    return out


def gone(pid: int) -> bool:
    """The process ``pid`` no longer runs (it does not exist, or is a zombie waiting to be reaped)."""
    st = _stat(pid)
    return st is None or st[0] in ("Z", "X")


def running(proc: Proc) -> bool:
    """The process ``proc`` (pid, start time) still runs."""
    st = _stat(proc[0])
    return st is not None and st[0] not in ("Z", "X") and st[3] == proc[1]


def descendants(pid: int) -> list[Proc]:
    """Every live process below ``pid`` (children, their children, ...)."""
    live = _live()
    out, frontier = [], {pid}
    while frontier:
        kids = [p for p, st in live.items() if st[1] in frontier]
        out += [(p, live[p][3]) for p in kids]
        frontier = set(kids)
    return out


def in_group(pgid: int) -> list[Proc]:
    """Every live process of the process group ``pgid``."""
    return [(p, st[3]) for p, st in _live().items() if st[2] == pgid]


def with_environment(name: str, value: str | None = None) -> list[Proc]:
    """Every live process whose environment (as it started) has ``name`` (set to ``value``, when given)."""
    found = []
    for p, st in _live().items():
        try:
            env = pathlib.Path(f"/proc/{p}/environ").read_bytes().split(b"\0")
        except OSError:  # gone meanwhile, or not ours to read
            continue
        for item in env:
            key, _, val = item.partition(b"=")
            if key == name.encode() and (value is None or val == value.encode()):
                found.append((p, st[3]))
                break
    return found


def wait_gone(procs, *, timeout_s: float = 30.0) -> list[Proc]:
    """Wait until none of ``procs`` runs, at most ``timeout_s`` [s]; returns those still running then."""
    deadline = time.monotonic() + timeout_s
    while (left := [p for p in procs if running(p)]) and time.monotonic() < deadline:
        time.sleep(0.05)
    return left


def kill(procs) -> None:
    """SIGKILL those of ``procs`` that still run (so that a failing test leaves nothing behind)."""
    for p in procs:
        if running(p):
            try:
                os.kill(p[0], signal.SIGKILL)
            except ProcessLookupError:
                pass


def command_line(pid: int) -> str:
    """The command line of ``pid`` ("" when it is gone)."""
    try:
        return pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


class Watch:
    """Every process that appears below ``pid`` (default: this one) while the ``with`` block runs,
    polled in a thread, with its command line; :meth:`left` says which of them still run afterwards.
    Processes that were below ``pid`` before the block (a fork server kept for the session) are not
    counted."""

    def __init__(self, pid: int | None = None, *, every_s: float = 0.05):
        self.pid, self.every_s = pid or os.getpid(), every_s
        self.seen: dict[Proc, str] = {}
        self._before: set[Proc] = set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, name="watch-children", daemon=True)

    def _look(self) -> None:
        for p in descendants(self.pid):
            if p not in self._before and p not in self.seen:
                self.seen[p] = command_line(p[0])

    def _poll(self) -> None:
        while not self._stop.is_set():
            self._look()
            self._stop.wait(self.every_s)

    def __enter__(self) -> Watch:
        self._before = set(descendants(self.pid))
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    def seen_with(self, needle: str) -> list[Proc]:
        """The seen processes whose command line contains ``needle``."""
        return [p for p, cmd in self.seen.items() if needle in cmd]

    def left(self, *, timeout_s: float = 30.0) -> list[Proc]:
        """The seen processes still running once ``timeout_s`` [s] has passed (or none, sooner)."""
        return wait_gone(self.seen, timeout_s=timeout_s)
