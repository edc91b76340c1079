"""Episodes run with the code of another git commit: a temporary worktree and a subprocess.

``excavsim regress --against REF`` compares the working tree with REF on the same seeds.
:func:`ref_checkout` checks REF out into a temporary ``git worktree`` (the current checkout is not
touched) and removes it afterwards, also on an error or Ctrl-C. :class:`CheckoutRun` runs episode
specifications there in a subprocess of this interpreter with ``PYTHONPATH`` set to the worktree,
so that the package, its ``configs/`` and its models are REF's; the subprocess first reports where
it imported ``excavsim`` from, and a run that imported another copy is refused. The subprocess
uses only :func:`~excavsim.loop.scenario.run_spec`, :func:`~excavsim.loop.scenario.episode_summary`
and :class:`~excavsim.loop.scenario.EpisodeSpec`, so REF needs no regression-suite code of its own.
"""

from __future__ import annotations

import contextlib
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator

from excavsim import constants
from excavsim.errors import ConfigError, DependencyError, ExcavsimError, UsageError
from excavsim.processes import OwnedProcess

# Runs in the worktree: reads jobs ({"name", "spec"} per line) from the file argv[2] and the renamings
# ({"tasks": {new: old}, "fields": {new: old}}) from argv[3], prints one JSON line per finished episode.
# Kept to APIs that older commits have too: a spec the revision refuses is tried once more with the tasks'
# and fields' older names; episode_summary took the result alone before the tasks were plug-ins; numpy
# numbers in a summary (an older revision's) are written as Python numbers.
DRIVER = r"""
import inspect, json, pathlib, sys
root = pathlib.Path(sys.argv[1]).resolve()
import excavsim
where = pathlib.Path(excavsim.__file__).resolve()
print(json.dumps({"excavsim": str(where)}), flush=True)
if root not in where.parents:
    sys.exit(f"excavsim was imported from {where}, not from the checkout {root}")
from excavsim.loop.scenario import EpisodeSpec, episode_summary, run_spec
aliases = json.loads(pathlib.Path(sys.argv[3]).read_text())
with_task = len(inspect.signature(episode_summary).parameters) > 1

def number(x):
    if hasattr(x, "item"):
        return x.item()
    raise TypeError(f"{type(x).__name__} is not JSON")

def older(spec):
    out = {aliases["fields"].get(k, k): v for k, v in spec.items()}
    out["task"] = aliases["tasks"].get(spec.get("task"), spec.get("task"))
    return out

for line in pathlib.Path(sys.argv[2]).read_text().splitlines():
    job = json.loads(line)
    try:
        spec = EpisodeSpec.model_validate(job["spec"])
    except Exception:
        spec = EpisodeSpec.model_validate(older(job["spec"]))
    res = run_spec(spec)
    summary = episode_summary(res, spec.task) if with_task else episode_summary(res)
    print(json.dumps({"name": job["name"], "seed": spec.seed, "summary": summary}, default=number), flush=True)
"""


def _git(args: list[str], repo: pathlib.Path) -> subprocess.CompletedProcess:
    try:
        return subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True, check=False)
    except FileNotFoundError:
        raise DependencyError("--against needs git on PATH") from None


def resolve_ref(ref: str, repo: pathlib.Path = constants.REPO_ROOT) -> str:
    """The commit hash of ``ref`` in ``repo``.

    Raises:
        ExcavsimError: ``repo`` is not a git checkout, or ``ref`` names no commit there.
    """
    if _git(["rev-parse", "--git-dir"], repo).returncode != 0:
        raise UsageError(f"--against needs a git checkout; {repo} is not one")
    done = _git(["rev-parse", "--verify", "--quiet", "--end-of-options", f"{ref}^{{commit}}"], repo)
    if done.returncode != 0 or not done.stdout.strip():
        raise ConfigError(f"git ref {ref!r} does not exist in {repo}; give a commit, branch or tag "
                          "(e.g. HEAD, HEAD~1, main or a commit hash)")
    return done.stdout.strip()


@contextlib.contextmanager
def ref_checkout(ref: str, repo: pathlib.Path = constants.REPO_ROOT) -> Iterator[pathlib.Path]:
    """Check ``ref`` out into a temporary detached worktree, yield its path, remove it on exit
    (normal, error, Ctrl-C, or SIGTERM, which meanwhile raises KeyboardInterrupt)."""
    commit = resolve_ref(ref, repo)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="excavsim-against-"))
    path = tmp / "checkout"
    main = threading.current_thread() is threading.main_thread()
    old_term = signal.signal(signal.SIGTERM, _interrupt) if main else None
    try:
        done = _git(["worktree", "add", "--detach", "--quiet", str(path), commit], repo)
        if done.returncode != 0:
            raise ExcavsimError(f"cannot check {ref!r} out into a worktree: {done.stderr.strip()}")
        yield path
    finally:
        if path.exists() and _git(["worktree", "remove", "--force", str(path)], repo).returncode != 0:
            shutil.rmtree(path, ignore_errors=True)
            _git(["worktree", "prune"], repo)  # forgets worktrees whose directory is gone
        shutil.rmtree(tmp, ignore_errors=True)
        if main:
            signal.signal(signal.SIGTERM, old_term if old_term is not None else signal.SIG_DFL)


def _interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


class CheckoutRun:
    """Episodes of another checkout, run in a background subprocess while this one works.

    ``start()`` launches it; ``results()`` waits and returns ``{(name, seed): summary}``; each
    finished episode is also handed to ``on_result(name, seed, summary)`` as it arrives (from a
    reader thread). Use it as a context manager: leaving ends a subprocess still running, and the
    subprocess ends with this process however it ends (an :class:`~excavsim.processes.OwnedProcess`).
    """

    def __init__(self, checkout: pathlib.Path, jobs: list[dict], *, label: str,
                 on_result: Callable[[str, int, dict], None] | None = None,
                 aliases: dict[str, dict[str, str]] | None = None):
        self.checkout = pathlib.Path(checkout).resolve()
        self.jobs, self.label, self.on_result = jobs, label, on_result
        self.aliases = aliases or {"tasks": {}, "fields": {}}
        self.proc: OwnedProcess | None = None
        self._found: dict[tuple[str, int], dict] = {}
        self._imported: str | None = None

    def start(self) -> CheckoutRun:
        """Write the job file and launch the subprocess."""
        job_file = self.checkout / ".excavsim-jobs.jsonl"
        job_file.write_text("".join(json.dumps(j) + "\n" for j in self.jobs))
        alias_file = self.checkout / ".excavsim-aliases.json"
        alias_file.write_text(json.dumps(self.aliases))
        env = {**os.environ, "PYTHONPATH": str(self.checkout), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "disable")}
        self._stderr = tempfile.TemporaryFile(mode="w+")
        self.proc = OwnedProcess([sys.executable, "-c", DRIVER, str(self.checkout), str(job_file), str(alias_file)],
                                 cwd=self.checkout, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                 stderr=self._stderr, text=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        return self

    def _read(self) -> None:
        for line in self.proc.stdout:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:  # something REF's code printed: not ours
                continue
            if "excavsim" in msg:
                self._imported = msg["excavsim"]
            elif "summary" in msg:
                self._found[(msg["name"], msg["seed"])] = msg["summary"]
                if self.on_result:
                    self.on_result(msg["name"], msg["seed"], msg["summary"])

    def results(self) -> dict[tuple[str, int], dict]:
        """Wait for the subprocess and return its episodes' summaries.

        Raises:
            ExcavsimError: it imported excavsim from elsewhere, failed, or returned too few episodes;
                the message ends with the tail of its error output.
        """
        code = self.proc.wait()
        self._reader.join()
        self._stderr.seek(0)
        tail = "\n".join(self._stderr.read().strip().splitlines()[-12:])
        if self._imported is not None and self.checkout not in pathlib.Path(self._imported).parents:
            raise ExcavsimError(f"the run of {self.label} imported excavsim from {self._imported}, not from its "
                                f"checkout {self.checkout}")
        if code != 0 or len(self._found) != len(self.jobs):
            raise ExcavsimError(f"the run of {self.label} failed (exit status {code}, {len(self._found)} of "
                                f"{len(self.jobs)} episodes){': ' + tail if tail else ''}")
        return dict(self._found)

    def __enter__(self) -> CheckoutRun:
        return self.start()

    def __exit__(self, *exc) -> None:
        try:
            if self.proc is not None:
                self.proc.end()
                self.proc.stdout.close()
        finally:
            self._stderr.close()
