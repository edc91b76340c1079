"""The processes a command starts, owned in one place: they end when the command ends.

A command that starts a process (the headless Rerun viewer of ``replay --screenshot``, a viewer window,
``rerun rrd verify``, another checkout's episodes for ``regress --against``) ends it when the command
ends: on success, on an error, on Ctrl-C, and when the command itself is killed, even by SIGKILL.
:class:`OwnedProcess` is how excavsim starts one; nothing else in the package calls
:class:`subprocess.Popen` for a process that may outlive a call.

How, on POSIX: the command runs under a small guard, this file run as a script (``python -I -S
processes.py OWNER_PID GRACE_S COMMAND...``), in a session of its own, so that a Ctrl-C in the
terminal reaches the owner only and the owner decides. The guard starts the command as the leader of a
new process group: the command and every process it starts (the ``rerun`` on the PATH is a Python shim
that runs the real viewer as its child) are in that group, and the guard ends the whole group:

- when the owner asks (:meth:`OwnedProcess.end`, and leaving a ``with`` block, on success, on an
  exception or on KeyboardInterrupt): SIGTERM to the group, SIGKILL to what is left after a grace
  (:meth:`OwnedProcess.kill`: SIGKILL at once);
- when the owner dies, however it dies (SIGTERM, SIGKILL, a crash): on Linux the kernel tells the guard
  at once (``prctl(PR_SET_PDEATHSIG)``), elsewhere the guard notices within a second that its parent
  changed; then it ends the group the same way;
- when the command exits by itself: SIGKILL to what it left in its group (its own children).

The guard passes the command's exit status on as its own (a command killed by a signal makes the guard
die of the same signal), so :attr:`~subprocess.Popen.returncode` reads as it would without it. Each
owned process and its children carry ``EXCAVSIM_STARTED_BY=<owner pid>`` in their environment, so that a
test can find what excavsim started and left running. On Windows there is no guard: the process starts
in a new process group and :meth:`OwnedProcess.end` terminates it.

Local campaign workers are started by :mod:`multiprocessing`, not here; each calls
:func:`exit_with_parent` first thing, and the campaign ends them itself on every other path.
"""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

STARTED_BY = "EXCAVSIM_STARTED_BY"  # the environment variable naming the pid of the process that started one
GRACE_S = 5.0  # how long a process may take to end on SIGTERM before it is killed [s]
WATCH_S = 1.0  # how often the guard looks at its parent where the kernel does not tell it [s]
GUARD_MARGIN_S = 5.0  # beyond the grace, how long the owner waits for the guard before killing it [s]
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _parent_death_signal(signum: int) -> bool:
    """Ask the Linux kernel to send ``signum`` to this process when its parent dies; False elsewhere
    or when it cannot (then the caller watches its parent itself)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


class OwnedProcess(subprocess.Popen):
    """A process a command starts and owns: a :class:`subprocess.Popen` whose process, and every process
    it starts, ends when the owner ends it, leaves its ``with`` block (on success, error or
    KeyboardInterrupt) or dies (see the module docstring).

    Leaving the ``with`` block *ends* the process (a plain Popen waits for it): wait for it inside the
    block (:meth:`wait`, :meth:`communicate`) when it should finish by itself.

    Args:
        args: the command and its arguments.
        grace_s: how long it may take to end on SIGTERM before it is killed [s].
        **kwargs: as for :class:`subprocess.Popen` (stdin, stdout, stderr, env, cwd, text, ...), except
            what would take the process out of its group (``start_new_session``, ``process_group``,
            ``preexec_fn``, ``shell``).

    Raises:
        FileNotFoundError: the command is not found (as Popen raises it).
        TypeError: one of the refused keyword arguments is given.
    """

    def __init__(self, args, *, grace_s: float = GRACE_S, **kwargs):
        refused = sorted({"start_new_session", "process_group", "preexec_fn", "shell"} & set(kwargs))
        if refused:
            raise TypeError(f"OwnedProcess keeps its process in a group it ends; it takes no {', '.join(refused)}")
        command = [os.fspath(a) for a in args]
        self.command, self.grace_s = command, float(grace_s)
        env = dict(os.environ if kwargs.get("env") is None else kwargs["env"])
        env[STARTED_BY] = str(os.getpid())
        kwargs["env"] = env
        if shutil.which(command[0], path=env.get("PATH", os.defpath)) is None:  # as Popen would say, not the guard
            raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), command[0])
        if os.name != "posix":
            super().__init__(command, creationflags=subprocess.CREATE_NEW_PROCESS_GROUP, **kwargs)
            return
        guard = [sys.executable, "-I", "-S", os.path.abspath(__file__), str(os.getpid()), f"{self.grace_s!r}",
                 *command]
        super().__init__(guard, start_new_session=True, **kwargs)

    def end(self) -> int:
        """End the process and every process it started, now: SIGTERM, then SIGKILL after the grace.
        Returns the exit status (negative: the signal that ended it). Waiting for the end is not cut
        short by a Ctrl-C (it is bounded by the grace); the KeyboardInterrupt is raised after it."""
        interrupted = False
        while self.poll() is None:
            try:
                self.terminate()
                self.wait(self.grace_s + GUARD_MARGIN_S)
            except subprocess.TimeoutExpired:  # the guard itself does not answer
                super().kill()
                self.wait()
            except KeyboardInterrupt:
                interrupted = True
        if interrupted:
            raise KeyboardInterrupt
        return self.returncode

    def kill(self) -> None:
        """End the process and every process it started at once (SIGKILL, no grace); :meth:`wait` for it."""
        if os.name == "posix":
            self.send_signal(signal.SIGUSR2)  # the guard kills the command's group, then exits
        else:
            super().kill()

    def __exit__(self, exc_type, value, traceback):
        try:
            self.end()
        finally:
            super().__exit__(exc_type, value, traceback)


def run(args, *, check: bool = False, **kwargs) -> subprocess.CompletedProcess:
    """:func:`subprocess.run` for a process the command owns: run ``args`` to its end as an
    :class:`OwnedProcess` (ended with its children on an error, a Ctrl-C or the death of this process).

    Raises:
        subprocess.CalledProcessError: ``check`` and it exited with a status other than 0.
    """
    with OwnedProcess(args, **kwargs) as proc:
        out, err = proc.communicate()
    if check and proc.returncode:
        raise subprocess.CalledProcessError(proc.returncode, proc.command, out, err)
    return subprocess.CompletedProcess(proc.command, proc.returncode, out, err)


def exit_with_parent() -> None:
    """In a worker process started by :mod:`multiprocessing`: exit at once when the process that
    started it dies, however it dies (even by SIGKILL).

    A thread waits on that process's sentinel (:func:`multiprocessing.parent_process`), which closes
    when it dies; this works with every start method (with ``forkserver`` the worker's parent is the
    fork server, so a parent-death signal would not do). Call it first thing in the worker; it does
    nothing in a process that :mod:`multiprocessing` did not start.
    """
    import multiprocessing
    from multiprocessing.connection import wait

    parent = multiprocessing.parent_process()
    if parent is None:
        return

    def watch() -> None:
        wait([parent.sentinel])
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


# -- the guard (this file run as a script; only the standard library, no excavsim) ----------------------------

def _command_group_dying_with_guard() -> None:
    """In the command's process, before it runs: lead a new process group, and die with the guard."""
    os.setpgid(0, 0)
    _parent_death_signal(signal.SIGKILL)


def _exited(child: subprocess.Popen) -> bool:
    """Whether the command has exited, without reaping it where the OS allows (its pid, hence its
    process group id, stays taken until it is reaped, so the group is never confused with another)."""
    if hasattr(os, "waitid"):
        try:
            return os.waitid(os.P_PID, child.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
        except ChildProcessError:
            pass
    return child.poll() is not None


def _signal_group(pgid: int, signum: int) -> None:
    try:
        os.killpg(pgid, signum)
    except (ProcessLookupError, PermissionError):
        pass


def _guard(argv: list[str]) -> None:
    """Run ``argv[2:]`` in a process group of its own and end that group when the owner (pid
    ``argv[0]``) asks (SIGTERM, SIGINT, SIGHUP) or dies, with ``argv[1]`` seconds of grace; exit as the
    command exited."""
    import select

    owner, grace_s, command = int(argv[0]), float(argv[1]), argv[2:]
    asked: list[int] = []
    wake_r, wake_w = os.pipe()  # signals write to it, so that select returns at once
    os.set_blocking(wake_r, False)
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGUSR2):  # SIGUSR2: at once, no grace
        signal.signal(signum, lambda s, _frame: asked.append(s))
    signal.signal(signal.SIGCHLD, lambda *_: None)
    signal.signal(signal.SIGUSR1, lambda *_: None)  # the owner died, or only the owner's thread that started us
    watch_s = 3600.0 if _parent_death_signal(signal.SIGUSR1) else WATCH_S

    def sleep(timeout_s: float) -> None:
        select.select([wake_r], [], [], max(0.0, timeout_s))
        while True:
            try:
                if not os.read(wake_r, 512):
                    break
            except BlockingIOError:
                break

    try:
        child = subprocess.Popen(command, preexec_fn=_command_group_dying_with_guard)
    except OSError as exc:
        sys.stderr.write(f"excavsim: cannot run {command[0]}: {exc.strerror}\n")
        sys.exit(127)
    while not _exited(child) and not asked and os.getppid() == owner:
        sleep(watch_s)
    if not _exited(child) and signal.SIGUSR2 not in asked:
        _signal_group(child.pid, signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        while not _exited(child) and time.monotonic() < deadline:
            sleep(min(0.5, deadline - time.monotonic()))
    _signal_group(child.pid, signal.SIGKILL)  # what is left: the command's own children, or a command that lingers
    code = child.wait()
    if code < 0:  # die of the same signal, so that the owner reads the command's status
        if -code not in (signal.SIGKILL, signal.SIGSTOP):
            signal.signal(-code, signal.SIG_DFL)
        signal.set_wakeup_fd(-1)
        os.kill(os.getpid(), -code)
        sys.exit(128 - code)  # a signal whose default is not to end a process
    sys.exit(code)


if __name__ == "__main__":
    _guard(sys.argv[1:])
