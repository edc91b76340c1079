"""Campaign hygiene: a worker killed mid-episode costs that episode (retried once, then ``failed``) and
not the campaign; workers die with the main process; corrupt result files are moved aside and re-run."""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest
import yaml

from tests.children import descendants, gone, kill, wait_gone
from tests.studies.campaign.test_campaign import TINY_BASE

from excavsim import constants
from excavsim.handoff.episode import EpisodeObserver
from excavsim.studies.campaign import runner as cmp


class KillsItsWorker(EpisodeObserver):
    """An observer that SIGKILLs the worker process running it after the episode's first scan."""

    def scanned(self, index, emap, accuracy):
        os.kill(os.getpid(), signal.SIGKILL)


def doomed_recorder(path: pathlib.Path) -> EpisodeObserver:
    """The campaign's extra observer factory (picklable, it travels to the workers): the seed-0 episode's
    worker is killed mid-episode, every time; the others observe nothing."""
    return KillsItsWorker() if path.stem.startswith("seed0-") else EpisodeObserver()


def cpu_s(pid: int) -> float:
    """CPU time the process ``pid`` has used so far [s] (0 once it is gone)."""
    try:
        fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except FileNotFoundError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_workers_exit_when_the_main_process_is_killed_or_terminated(tmp_path, sig):
    """SIGKILL (no cleanup possible: the workers see the main process's sentinel close) or SIGTERM (the
    main process ends its workers and exits 130) of the CLI alone, once its workers are into their
    episodes (2 s of CPU each: past the imports, which take about 1 s): its forkserver and workers go.
    The episodes must outlast that: tiny.yaml's run in about 1 s each now, so six of three digs with
    the default scans (several seconds each) run here; the kill comes long before they end."""
    spec = tmp_path / "slower.yaml"
    spec.write_text(yaml.safe_dump({"name": "slower", "base": {**TINY_BASE, "dig_budget": 3, "sensing": {}},
                                    "grid": {"seed": list(range(6))}}))
    cmd = [sys.executable, "-m", "excavsim.cli", "campaign", str(spec), "--out", str(tmp_path / "out"),
           "--workers", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=constants.REPO_ROOT,
                            start_new_session=True)
    below = []
    try:
        deadline = time.monotonic() + 120
        # the forkserver and two workers below it, each busy
        while len(below := descendants(proc.pid)) < 3 or sorted(cpu_s(p) for p, _ in below)[-2] < 2.0:
            assert proc.poll() is None and time.monotonic() < deadline, "the workers never got going"
            time.sleep(0.05)
        os.kill(proc.pid, sig)
        assert proc.wait(timeout=60) == (-signal.SIGKILL if sig == signal.SIGKILL else 130)
        left = wait_gone(below, timeout_s=60)
        assert not left, left
    finally:
        kill(below)  # never leave one behind, even when the test fails
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_sigterm_interrupts_the_campaign_loop_as_sigint_does():
    before = signal.getsignal(signal.SIGTERM)
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with cmp._sigterm_interrupts():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the handler raises at once, before this returns
            reached.append(True)
    assert not reached and signal.getsignal(signal.SIGTERM) == before  # the handler is put back


@pytest.mark.parametrize(("text", "problem"), [
    ("{}", "its id is 'None'"),
    ('{"id": "e", "status": "ok", "summ', "unreadable: JSONDecodeError"),
    ("[1, 2]", "a JSON list, not an object"),
    ('{"id": "other", "status": "ok"}', "its id is 'other', not 'e'"),
    ('{"id": "e", "status": "done"}', "status 'done' (allowed: ok, error, failed)"),
    ('{"id": "e", "status": "ok", "summary": null}', "status ok without a summary"),
    ('{"id": "e", "status": "ok", "summary": {"end": "done"}}', "status ok without a summary"),
    ('{"id": "e", "status": "failed"}', "status failed without an error text"),
    ("\udcff", "unreadable: UnicodeDecodeError"),
])
def test_a_result_file_that_is_not_a_result_is_named_with_its_problem(tmp_path, text, problem):
    path = tmp_path / "e.json"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    assert problem in cmp.result_problem(path, "e")


def test_a_valid_result_file_has_no_problem(tmp_path):
    path = tmp_path / "e.json"
    path.write_text(json.dumps({"id": "e", "status": "ok", "summary": {"end": "done", "digs": 3}}))
    assert cmp.result_problem(path, "e") is None
    path.write_text(json.dumps({"id": "e", "status": "error", "error": "ExcavsimError: no"}))
    assert cmp.result_problem(path, "e") is None


@pytest.mark.slow
def test_a_resumed_campaign_reruns_corrupt_results_and_survives_a_worker_killed_mid_episode(tmp_path):
    """Two episodes, resumed over a result file ``{}`` (seed 0) and a truncated one (seed 1): both are
    moved aside and run again; the seed-0 episode's worker is killed mid-episode on both attempts, so
    it is recorded ``failed`` while seed 1 completes; no worker is left."""
    spec = cmp.parse_campaign({"name": "doomed", "base": TINY_BASE, "grid": {"seed": [0, 1]}})
    episodes = cmp.expand_grid(spec)
    ep_dir = tmp_path / "episodes"
    ep_dir.mkdir()
    bad = {episodes[0].id: "{}", episodes[1].id: '{"id": "' + episodes[1].id + '", "status": "o'}
    for ep_id, text in bad.items():
        (ep_dir / f"{ep_id}.json").write_text(text)
    (ep_dir / "corrupt").mkdir()
    (ep_dir / "corrupt" / f"{episodes[0].id}.json").write_text("an earlier one")  # never replaced
    lines = []
    report = cmp.run_campaign(spec, tmp_path, workers=2, resume=True, observer=doomed_recorder,
                              progress=lines.append)
    # the corrupt files: moved aside, named, their episodes run again
    assert (ep_dir / "corrupt" / f"{episodes[0].id}.json").read_text() == "an earlier one"
    assert (ep_dir / "corrupt" / f"{episodes[0].id}.json.1").read_text() == "{}"
    assert (ep_dir / "corrupt" / f"{episodes[1].id}.json").read_text() == bad[episodes[1].id]
    notes = [line for line in lines if "is not a valid result" in line]
    assert len(notes) == 2 and all("its episode runs again" in n for n in notes)
    assert "2 episodes, 0 already done, 2 to run" in "\n".join(lines)
    assert all(cmp.result_problem(ep_dir / f"{e.id}.json", e.id) is None for e in episodes)
    # the killed worker: its episode retried once, then failed; the campaign went on
    assert report.ran == 2 and report.errors == 1
    doomed, fine = (json.loads((ep_dir / f"{e.id}.json").read_text()) for e in episodes)
    assert doomed["status"] == "failed" and doomed["summary"] is None
    assert "died (killed by SIGKILL) on each of 2 attempts" in doomed["error"]
    assert fine["status"] == "ok" and fine["summary"]["digs"] == 1
    retried = [line for line in lines if "running it again" in line]
    assert len(retried) == 1 and retried[0].startswith(episodes[0].id)
    assert sum("FAILED" in line for line in lines) == 1
    assert [r["status"] for r in report.rows] == ["failed", "ok"]
    # every worker that ran is gone: the two killed ones (their PIDs are in the messages; a killed worker
    # never runs again, so they differ) and the one that finished its episode (workers persist and take
    # episodes from a queue, so the retry may have run on it after it finished seed 1: it may be the
    # second killed one)
    pids = [int(text.split("worker process ")[1].split()[0]) for text in (retried[0], doomed["error"])]
    assert pids[0] != pids[1], pids
    pids.append(fine["pid"])
    assert fine["pid"] != pids[0] and all(gone(p) for p in pids), pids
    assert not [p for p, _ in descendants(os.getpid()) if p in pids]
    again = cmp.run_campaign(spec, tmp_path, workers=2, resume=True, progress=None)  # a failed one is a result
    assert again.ran == 0 and [r["status"] for r in again.rows] == ["failed", "ok"]
