"""The processes a command starts end with it (excavsim.processes): on success, on an error, on Ctrl-C,
when the command exits by itself leaving children behind, and when the process that owns them is
killed (SIGTERM, SIGKILL). Each command here is a shell that starts a child of its own, as the
``rerun`` on the PATH (a Python shim) starts the real viewer."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from excavsim.processes import STARTED_BY, OwnedProcess
from tests.children import descendants, gone, in_group, kill, wait_gone

SHELL_WITH_CHILD = ["sh", "-c", "sleep 300 & wait"]  # a command that starts a process of its own


def family(proc: OwnedProcess) -> list:
    """The guard's command and the processes below it, once the command's child has started."""
    deadline = time.monotonic() + 30
    while len(below := descendants(proc.pid)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, "the command never started its child"
        time.sleep(0.02)
    return below


def test_leaving_the_block_ends_the_command_and_its_children():
    with OwnedProcess(SHELL_WITH_CHILD) as proc:
        below = family(proc)
        pgid = os.getpgid(below[0][0])
        assert pgid != os.getpgid(0)  # its own process group, apart from the owner's
        assert len(in_group(pgid)) == 2  # the shell and its sleep
    left = wait_gone(below)
    kill(left)
    assert not left, "the command or its child outlived the with block"
    assert gone(proc.pid) and proc.returncode == -signal.SIGTERM  # the command ended on SIGTERM


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_an_error_or_ctrl_c_in_the_block_ends_the_command(error):
    below = []
    with pytest.raises(error):
        with OwnedProcess(SHELL_WITH_CHILD) as proc:
            below = family(proc)
            raise error("stop")
    left = wait_gone(below)
    kill(left)
    assert below and not left


def test_a_command_that_exits_takes_what_it_left_running_with_it():
    """The shell exits 3 with its sleep still running: the sleep is killed, the status passes on."""
    with OwnedProcess(["sh", "-c", "sleep 300 & echo $!; exit 3"], stdout=subprocess.PIPE, text=True) as proc:
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 3
    child = int(out)
    deadline = time.monotonic() + 30
    while not gone(child) and time.monotonic() < deadline:
        time.sleep(0.02)
    if not gone(child):
        os.kill(child, signal.SIGKILL)
        pytest.fail("the child the command left behind still runs")


def test_the_exit_status_is_the_commands():
    with OwnedProcess(["sh", "-c", "exit 0"]) as proc:
        assert proc.wait(timeout=60) == 0
    with OwnedProcess(["sh", "-c", "kill -KILL $$"]) as proc:
        assert proc.wait(timeout=60) == -signal.SIGKILL  # died of a signal: the same signal, negative


def test_a_command_deaf_to_sigterm_is_killed_after_the_grace():
    with OwnedProcess(["sh", "-c", "trap '' TERM; sleep 300 & wait"], grace_s=0.5) as proc:
        below = family(proc)
    left = wait_gone(below)
    kill(left)
    assert not left


def test_output_pipes_and_the_owner_mark_reach_the_command():
    with OwnedProcess(["sh", "-c", f"echo ${STARTED_BY}"], stdout=subprocess.PIPE, text=True) as proc:
        out, _ = proc.communicate(timeout=60)
    assert out.strip() == str(os.getpid())


def test_a_missing_command_or_a_way_out_of_the_group_is_refused():
    with pytest.raises(FileNotFoundError):
        OwnedProcess(["no-such-command-excavsim"])
    for escape in ({"start_new_session": True}, {"preexec_fn": os.setsid}, {"shell": True}):
        with pytest.raises(TypeError, match="keeps its process in a group"):
            OwnedProcess(SHELL_WITH_CHILD, **escape)


OWNER = """
import sys, time
from excavsim.processes import OwnedProcess
proc = OwnedProcess(["sh", "-c", "sleep 300 & wait"])
print(proc.pid, flush=True)
time.sleep(300)
"""


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_the_command_dies_with_its_owner(sig):
    """The owner is killed (no cleanup of its own: SIGKILL, or SIGTERM's default action) while its
    command runs: the guard sees it die and ends the command and its child."""
    owner = subprocess.Popen([sys.executable, "-c", OWNER], stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    below = []
    try:
        guard = int(owner.stdout.readline())
        deadline = time.monotonic() + 60
        while len(below := descendants(guard)) < 2:  # the shell and its sleep
            assert time.monotonic() < deadline, "the owner's command never started"
            time.sleep(0.02)
        below += [p for p in descendants(owner.pid) if p[0] == guard]
        os.kill(owner.pid, sig)
        assert owner.wait(timeout=60) == -sig
        assert not wait_gone(below), "the command (or the guard) outlived its owner"
    finally:
        kill(below)
        if owner.poll() is None:
            owner.kill()
            owner.wait()
        owner.stdout.close()


def test_run_is_subprocess_run_for_an_owned_process():
    from excavsim import processes

    done = processes.run(["sh", "-c", "echo made"], stdout=subprocess.PIPE, text=True)
    assert (done.returncode, done.stdout) == (0, "made\n")
    with pytest.raises(subprocess.CalledProcessError) as info:
        processes.run(["sh", "-c", "exit 4"], check=True)
    assert info.value.returncode == 4


def test_kill_ends_the_whole_group_at_once():
    """A plain SIGKILL to the guard would leave the command's own child behind (as killing the rerun
    shim left the viewer): kill() takes the group."""
    with OwnedProcess(["sh", "-c", "trap '' TERM; sleep 300 & wait"], grace_s=300) as proc:
        below = family(proc)
        proc.kill()
        assert proc.wait(timeout=60) is not None
        left = wait_gone(below)
    kill(left)
    assert not left
