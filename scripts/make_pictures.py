"""Make the README's pictures (``make pictures``): the demo episode in the Rerun viewer at three moments,
the plan's figures and a campaign plot, downscaled into docs/images/.

Needs the headless viewer's Vulkan (a GPU driver, or Debian's ``mesa-vulkan-drivers``). Runs the
default demo episode (the one ``make demo`` records), ``excavsim plan`` and the tiny campaign, in
runs/pictures/ (about two minutes on two CPUs).

Usage: .venv/bin/python scripts/make_pictures.py [--out docs/images] [--work runs/pictures]
"""

from __future__ import annotations

import argparse
import pathlib
import re
import shutil
import subprocess
import sys

from PIL import Image

from excavsim.record.replay import log_entries, screenshots

MAX_WIDTH = 1000  # every picture is downscaled to at most this width [px]
MAX_BYTES = 300_000  # and must end up at most this big


def excavsim(*args: str) -> None:
    """Run the excavsim command of this Python's environment; fail on its failure."""
    exe = pathlib.Path(sys.executable).with_name("excavsim")
    subprocess.run([str(exe), *args], check=True, stdout=subprocess.DEVNULL)


def shrink(src: pathlib.Path, dst: pathlib.Path) -> None:
    """Copy a PNG downscaled to :data:`MAX_WIDTH` and to a 256-colour palette (small files)."""
    img = Image.open(src).convert("RGB")
    if img.width > MAX_WIDTH:
        img = img.resize((MAX_WIDTH, round(img.height * MAX_WIDTH / img.width)), Image.LANCZOS)
    img.quantize(256, method=Image.Quantize.MEDIANCUT).save(dst, optimize=True)
    size = dst.stat().st_size
    if size > MAX_BYTES:
        raise SystemExit(f"{dst} is {size / 1000:.0f} kB, over {MAX_BYTES / 1000:.0f} kB")
    print(f"{dst} ({img.width}x{img.height}, {size / 1000:.0f} kB)")


def moments(rrd: pathlib.Path) -> dict[str, float]:
    """When to show the episode: before the first dig (its plan shown), in the middle of the middle dig,
    and the end [s of simulated time], from the recording's log."""
    log = log_entries(rrd)
    plans = [t for t, text in log if re.match(r"plan \d+: ", text)]
    digs = [t for t, text in log if re.match(r"dig \d+ ", text)]
    if not plans or not digs:
        raise SystemExit(f"{rrd}: no dig in the log")
    k = len(digs) // 2  # the middle dig: it starts after its plan and ends at its log line
    start = max(t for t in plans if t <= digs[k])
    return {"before": plans[0], "mid": (start + digs[k]) / 2, "done": log[-1][0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/images", help="where the pictures go (default docs/images)")
    parser.add_argument("--work", default="runs/pictures", help="scratch directory (default runs/pictures)")
    args = parser.parse_args()
    out, work = pathlib.Path(args.out), pathlib.Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)

    rrd = work / "demo.rrd"
    excavsim("trench", "--record", str(rrd))  # the demo episode of `make demo`
    times = moments(rrd)
    shots = [(t, work / f"demo_{name}.png") for name, t in times.items()]
    screenshots(rrd, shots, size=(1600, 1000))
    for _, png in shots:
        shrink(png, out / png.name)

    excavsim("plan", "--out", str(work / "plan"))
    for name in ("feasible_sets", "limits", "dig"):
        shrink(work / "plan" / f"{name}.png", out / f"plan_{name}.png")

    excavsim("campaign", "configs/campaigns/tiny.yaml", "--out", str(work / "campaign"), "--workers", "2")
    for png in sorted((work / "campaign" / "plots").glob("*.png")):
        shrink(png, out / f"campaign_{png.name}")


if __name__ == "__main__":
    main()
