"""The behaviour fingerprint of a checkout: proof that a restructuring changed no behaviour.

``record DIR`` runs ``excavsim trench`` (the default episode, saving every scanned map),
``trench --goal small --seed 3`` (likewise), ``regress`` (writing every scenario's metrics to full
precision) and ``plan --no-figures`` with this interpreter and this checkout, and keeps their output
in ``DIR``. ``compare A B`` compares two fingerprints: the printed tables and summaries line by line
with the timings masked, the regression metrics exactly, and every scanned map bit for bit. Episodes
are deterministic for a seed on one machine, so a pure refactoring must compare identical there;
across machines floating-point differences grow into different digs, and a comparison means
nothing.

    git worktree add /tmp/old HEAD~1                       # the commit before the change
    python scripts/fingerprint.py record /tmp/before --repo /tmp/old
    python scripts/fingerprint.py record /tmp/after        # this checkout
    python scripts/fingerprint.py compare /tmp/before /tmp/after

Takes about a minute per fingerprint on 2 cores.
"""

from __future__ import annotations

import argparse
import difflib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
RUNS = {  # output file -> arguments of the excavsim command
    "trench_default.txt": ["trench", "--save-maps", "{dir}/maps_default"],
    "trench_small3.txt": ["trench", "--goal", "small", "--seed", "3", "--save-maps", "{dir}/maps_small3"],
    "regress.txt": ["regress", "--all", "--update", "--baseline", "{dir}/regress_full.json"],
    "plan.txt": ["plan", "--no-figures"],
}
# wall-clock times, and the lines that name the checkout or the output directory
TIMING = re.compile(r"\d+\.\d+ s\b|\d+\.\d+ s wall")
VOLATILE = ("maps saved in", "baseline written", "golden scenarios of", "recorded to")


def record(out: pathlib.Path, repo: pathlib.Path = REPO) -> None:
    """Run the commands of :data:`RUNS` in checkout ``repo`` and keep their output (and the maps and
    metrics) in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(repo / "configs" / "regress" / "baseline.json", out / "regress_full.json")
    env = {**os.environ, "MUJOCO_GL": "disable", "PYTHONPATH": str(repo)}
    for name, args in RUNS.items():
        cmd = [sys.executable, "-m", "excavsim.cli", *(a.format(dir=out) for a in args)]
        print("running", " ".join(cmd[2:]), flush=True)
        done = subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True)
        (out / name).write_text(done.stdout + done.stderr + f"exit status {done.returncode}\n")


def _lines(path: pathlib.Path) -> list[str]:
    return [TIMING.sub("T", line) for line in path.read_text().splitlines()
            if not any(v in line for v in VOLATILE)]


def compare(a: pathlib.Path, b: pathlib.Path) -> int:
    """Print what differs between two fingerprints; returns the number of differences."""
    bad = 0
    for name in RUNS:
        la, lb = _lines(a / name), _lines(b / name)
        if la == lb:
            print(f"same  {name} ({len(la)} lines)")
        else:
            bad += 1
            print(f"DIFF  {name}")
            for line in list(difflib.unified_diff(la, lb, lineterm="", n=1))[:40]:
                print("     ", line)
    same = json.loads((a / "regress_full.json").read_text()) == json.loads((b / "regress_full.json").read_text())
    print(f"{'same ' if same else 'DIFF '} regress metrics (full precision)")
    bad += not same
    for maps in sorted(a.glob("maps_*")):
        files = sorted(maps.glob("*.npz"))
        other = sorted((b / maps.name).glob("*.npz"))
        if [f.name for f in files] != [f.name for f in other]:
            bad += 1
            print(f"DIFF  {maps.name}: {len(files)} maps against {len(other)}")
            continue
        differ = []
        for f in files:
            with np.load(f) as za, np.load(b / maps.name / f.name) as zb:
                differ += [f"{f.name}:{k}" for k in za.files if not np.array_equal(za[k], zb[k], equal_nan=True)]
        bad += len(differ)
        detail = ", ".join(differ) if differ else "bit for bit"
        print(f"{'DIFF ' if differ else 'same '} {maps.name}: {len(files)} maps, {detail}")
    print("IDENTICAL" if not bad else f"{bad} DIFFERENCES")
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="run the commands and keep their output in DIR")
    rec.add_argument("dir", type=pathlib.Path)
    rec.add_argument("--repo", type=pathlib.Path, default=REPO, help="the checkout to run (default: this one)")
    cmp = sub.add_parser("compare", help="compare two fingerprints")
    cmp.add_argument("a", type=pathlib.Path)
    cmp.add_argument("b", type=pathlib.Path)
    args = parser.parse_args(argv)
    if args.command == "record":
        record(args.dir, args.repo.resolve())
        return 0
    return 1 if compare(args.a, args.b) else 0


if __name__ == "__main__":
    sys.exit(main())
