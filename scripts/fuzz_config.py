"""A large fuzz of the configuration loader and the commands, outside the test suite (issue #16).

Runs ``tests/test_fuzz_config.py`` with ``EXAMPLES`` cases per configuration kind (ten kinds) and a
third as many per command (eight commands), unseeded, and tallies what every case did: loaded, a clean error (the
package's own, exit status 2), a traceback (any other exception) or a hang (still running after the
test's ``HANG_S``). Usage::

    .venv/bin/python scripts/fuzz_config.py [EXAMPLES]      # default 100: about 1260 cases
"""

from __future__ import annotations

import collections
import json
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent


def main() -> int:
    """Run the fuzz, print the tally per kind and in total; exit 1 if any case gave a traceback or hung."""
    examples = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    with tempfile.TemporaryDirectory() as tmp:
        report = pathlib.Path(tmp) / "fuzz.jsonl"
        env = {**os.environ, "EXCAVSIM_FUZZ_EXAMPLES": str(examples), "EXCAVSIM_FUZZ_REPORT": str(report)}
        status = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                 str(ROOT / "tests" / "test_fuzz_config.py")], cwd=ROOT, env=env).returncode
        rows = [json.loads(line) for line in report.read_text().splitlines()] if report.exists() else []
    by_kind: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for row in rows:
        by_kind[row["kind"]][row["outcome"]] += 1
    outcomes = ("loaded", "clean_error", "traceback", "hang")
    print(f"\n{'kind':<16}" + "".join(f"{o:>13}" for o in outcomes) + f"{'cases':>8}")
    total = collections.Counter()
    for kind in sorted(by_kind):
        total.update(by_kind[kind])
        counts = by_kind[kind]
        print(f"{kind:<16}" + "".join(f"{counts[o]:>13}" for o in outcomes) + f"{sum(counts.values()):>8}")
    print(f"{'total':<16}" + "".join(f"{total[o]:>13}" for o in outcomes) + f"{sum(total.values()):>8}")
    for row in rows:
        if row["outcome"] in ("traceback", "hang"):
            print(f"{row['kind']}: {row['outcome']}: {row['detail']}")
    return 1 if status or total["traceback"] or total["hang"] else 0


if __name__ == "__main__":
    sys.exit(main())
