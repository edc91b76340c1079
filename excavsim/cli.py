"""The ``excavsim`` command. It only parses arguments and calls the package.

Errors that excavsim raises on purpose (bad configuration, unreachable poses, diverging physics)
print one clear message and exit with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import sys
import tempfile

from excavsim.errors import ExcavsimError, shorten

MAX_SEED = 2**32 - 1  # seeds are unsigned 32-bit numbers, as EpisodeSpec.seed: exact in every result file
MAX_DIG_BUDGET = 1000  # EpisodeSpec.dig_budget's bound
VALIDATE_KINDS = ("robot", "scene", "soils", "sensing", "planner", "executor", "goal", "spec", "campaign",
                  "experiment")  # the kinds of file `validate` checks (see _validate_file)


# -- argument checks: ranges and paths, at parse time (exit 2 before any work) ---------------------
def _int_in(lo: int, hi: int):
    """An argparse type: an integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not an integer") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value} is out of range (allowed: {lo} to {hi})")
        return value
    return parse


def _float_in(lo: float, hi: float, *, low_open: bool = False, high_open: bool = False):
    """An argparse type: a finite number in [lo, hi] (``low_open``, ``high_open``: without that end)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a number") from None
        if not (math.isfinite(value) and (value > lo if low_open else value >= lo)
                and (value < hi if high_open else value <= hi)):
            low, high = (">" if low_open else ">="), ("<" if high_open else "<=")
            raise argparse.ArgumentTypeError(f"{shorten(text)} is out of range (allowed: {low} {lo:g} and "
                                             f"{high} {hi:g})")
        return value
    return parse


def _check_creatable(path: pathlib.Path, shown: str) -> None:
    """Raise ArgumentTypeError unless ``path`` can be created: its nearest existing ancestor is a writable directory."""
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise argparse.ArgumentTypeError(f"{shown}: {shorten(str(ancestor))} is a file, so {shown} cannot be "
                                         "created in it; allowed: a path under a directory")
    try:
        with tempfile.TemporaryFile(dir=ancestor):
            pass
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{shown}: cannot write in {shorten(str(ancestor))} ({exc.strerror}); "
                                         "allowed: a writable place") from None


def _path_text(text: str) -> tuple[pathlib.Path, str]:
    """``text`` as a path and as messages show it; ArgumentTypeError if it cannot be a path."""
    shown = shorten(repr(text), 200)
    if not text or "\0" in text:
        raise argparse.ArgumentTypeError(f"{shown} is not a path")
    return pathlib.Path(text), shown


def _out_dir(text: str) -> str:
    """An argparse type: an output directory, existing and writable, or creatable under a writable directory."""
    path, shown = _path_text(text)
    try:
        if path.exists():
            if not path.is_dir():
                raise argparse.ArgumentTypeError(f"{shown} exists and is not a directory; allowed: a directory "
                                                 "(created if missing)")
            _check_creatable(path / "x", shown)
        else:
            _check_creatable(path, shown)
    except OSError as exc:  # e.g. a name too long
        raise argparse.ArgumentTypeError(f"{shown}: {exc.strerror or exc}") from None
    return text


def _out_file(suffixes: tuple[str, ...]):
    """An argparse type: a file to write (or to read if it exists), with one of ``suffixes`` when given."""
    def parse(text: str) -> str:
        path, shown = _path_text(text)
        if suffixes and path.suffix not in suffixes:
            raise argparse.ArgumentTypeError(f"{shown}: allowed: a file name ending in {' or '.join(suffixes)}")
        try:
            if path.exists():
                if not path.is_file():
                    raise argparse.ArgumentTypeError(f"{shown} exists and is not a file; allowed: a file path")
                return text  # read or overwritten: whoever opens it says if it cannot
            _check_creatable(path, shown)
        except OSError as exc:
            raise argparse.ArgumentTypeError(f"{shown}: {exc.strerror or exc}") from None
        return text
    return parse


def _name_or_path(text: str) -> str:
    """An argparse type: a preset name or a file path, at most 4096 characters and without NUL."""
    if len(text) > 4096 or "\0" in text:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))}: allowed: a name or a path of at most 4096 "
                                         "characters")
    return text


_seed = _int_in(0, MAX_SEED)
_dig_budget = _int_in(1, MAX_DIG_BUDGET)


def _cmd_demo(args: argparse.Namespace) -> int:
    import math

    from excavsim.config import load_robot_config, load_scene_config
    from excavsim.handoff.episode import format_episode
    from excavsim.loop.demo import DEMO_ACTION, run_demo
    from excavsim.world.simulation import Simulation

    robot = load_robot_config(args.robot_config)
    scene = load_scene_config(args.scene_config)
    k, alpha, d1, d2 = DEMO_ACTION
    print(f"excavsim demo: one hand-picked dig into {scene.soil} (k {k:.2f} m, alpha {math.degrees(alpha):.0f} deg, "
          f"d1 {d1:.2f} m, d2 {d2:.2f} m): scan, dig, dump, settle, scan (seed {args.seed})")
    sim = Simulation(robot, scene, seed=args.seed)
    print(format_episode(run_demo(sim, seed=args.seed, progress=print)))
    return 0


def _cmd_cycle(args: argparse.Namespace) -> int:
    from excavsim.handoff.episode import format_episode
    from excavsim.loop.scenario import EpisodeSpec, run_spec

    spec = EpisodeSpec(name="cycle", dig_budget=1, seed=args.seed)
    print(f"excavsim cycle: park, scan, plan, dig, settle, scan: one dig of the {spec.goal} trench (seed {args.seed})")
    result = run_spec(spec, progress=print, robot_path=args.robot_config, scene_path=args.scene_config)
    print(format_episode(result))
    return 0


def _cmd_trench(args: argparse.Namespace) -> int:
    from excavsim.handoff.episode import format_episode
    from excavsim.config import parse_config
    from excavsim.loop.scenario import EpisodeSpec, ResolvedSpec, load_spec, run_spec

    spec = load_spec(args.spec) if args.spec else EpisodeSpec()
    given = {"goal": args.goal, "soil": args.soil, "dig_budget": args.dig_budget, "seed": args.seed}
    if args.record and not args.record.endswith(".rrd"):
        raise ExcavsimError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    spec = parse_config({**spec.model_dump(), **{k: v for k, v in given.items() if v is not None}}, EpisodeSpec,
                        source="the command line")
    ResolvedSpec(spec, robot_path=args.robot_config, scene_path=args.scene_config)  # every file checked first
    if spec.task != "trench":  # another task of the one episode (loading from a pile): run and print it
        if args.record or args.live is not None or args.save_maps:
            raise ExcavsimError(f"--record, --live and --save-maps follow trenching episodes; the spec's task is "
                                f"{spec.task}")
        from excavsim.loop.loading_mujoco import format_run

        print(f"excavsim trench --spec: task {spec.task}, machine {spec.machine_name}, {spec.dig_budget} digs at "
              f"most, seed {spec.seed}")
        print(format_run(run_spec(spec, progress=print)))
        return 0
    observer = None
    if args.record or args.live is not None:
        from excavsim.record import RerunRecorder
        from excavsim.record.live import viewer_url

        live = viewer_url(args.live or None) if args.live is not None else None  # checked before the episode
        if live:
            print(f"streaming the episode live to {live}")
        observer = RerunRecorder(args.record, live=live)
    if args.save_maps:
        from excavsim.handoff.episode import ObserverGroup
        from excavsim.loop.episode import MapWriter

        observer = ObserverGroup(observer, MapWriter(args.save_maps))
    goal = spec.goal if isinstance(spec.goal, str) else (spec.goal.name or "inline goal")
    print(f"excavsim trench: {goal} trench, {spec.dig_budget} digs at most, soil {spec.soil or 'of the scene'}, "
          f"seed {spec.seed}")
    result = run_spec(spec, progress=print, observer=observer, robot_path=args.robot_config,
                      scene_path=args.scene_config)
    print(format_episode(result))
    if args.record:
        print(f"recorded to {args.record}; replay it with: excavsim replay {args.record}")
    if args.save_maps:
        print(f"scanned maps saved in {args.save_maps} (map_NN.npz); plan on one with: "
              f"excavsim plan --map {args.save_maps}/map_02.npz")
    return 0


RRD_MAGIC = b"RRF2"  # the first bytes of a Rerun 0.2x+ recording
VERIFY_TIMEOUT_S = 300  # the longest `rerun rrd verify` may take before replay gives up [s]


def _check_recording(path: str) -> None:
    """Refuse ``path`` unless it is a Rerun recording the installed Rerun can load (``rerun rrd verify``).

    A recording cut short (an episode killed before it closed its file) has no footer: it is
    accepted with a warning, since the viewer shows what it holds.

    Raises:
        ExcavsimError: naming the file and what is wrong with it.
    """
    import re
    import subprocess

    from excavsim.record.replay import rerun_command

    shown = shorten(path, 200)
    try:
        if not os.path.isfile(path):
            raise ExcavsimError(f"no recording at {shown}: give an .rrd file written by `excavsim trench --record "
                                "FILE.rrd`")
        with open(path, "rb") as f:
            head = f.read(len(RRD_MAGIC))
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or exc
        raise ExcavsimError(f"{shown}: cannot read the recording ({why}); give an .rrd file written by "
                            "`excavsim trench --record FILE.rrd`") from None
    if head != RRD_MAGIC:
        raise ExcavsimError(f"{shown}: not a Rerun recording (it does not start with {RRD_MAGIC.decode()}); give an "
                            ".rrd file written by `excavsim trench --record FILE.rrd`")
    verify = [*rerun_command(path)[:-1], "rrd", "verify"]
    for footers in ("true", "false"):
        try:
            with subprocess.Popen([*verify, "--check-footers", footers, path], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, errors="replace") as proc:
                try:
                    out, err = proc.communicate(timeout=VERIFY_TIMEOUT_S)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    raise ExcavsimError(f"{shown}: `rerun rrd verify` did not finish in {VERIFY_TIMEOUT_S} s") from None
        except OSError as exc:
            raise ExcavsimError(f"{shown}: cannot run `rerun rrd verify` ({exc.strerror})") from None
        verified = re.search(r"(\d+) files? verified", out + err)
        if proc.returncode == 0 and verified and int(verified.group(1)) == 0:
            raise ExcavsimError(f"{shown}: a Rerun header and no recording in it (`rerun rrd verify` found nothing "
                                "to verify); give an .rrd file written by `excavsim trench --record FILE.rrd`")
        if proc.returncode == 0:
            if footers == "false":
                print(f"excavsim: warning: {shown} has no footer (the recording was cut short); replaying what it "
                      "holds", file=sys.stderr)
            return
    lines = [ln for ln in err.splitlines() if ln.strip()]
    raise ExcavsimError(f"{shown}: Rerun cannot load this recording: {shorten(lines[-1] if lines else out, 200)}")


def _sim_time(text: str) -> float | None:
    """An argparse type of ``replay --time``: simulated seconds (a number >= 0), or ``end``."""
    if text.strip().lower() == "end":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a time; allowed: seconds of simulated "
                                         "time (>= 0) or 'end'") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{shorten(text)} is out of range (allowed: >= 0 s, or 'end')")
    return value


def _window_size(text: str) -> tuple[int, int]:
    """An argparse type of ``replay --size``: WIDTHxHEIGHT in logical points, each 320 to 7680."""
    import re

    m = re.fullmatch(r"\s*(\d{1,5})\s*[xX]\s*(\d{1,5})\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"{shorten(repr(text))} is not a size; allowed: WIDTHxHEIGHT, e.g. 1600x1000")
    w, h = int(m.group(1)), int(m.group(2))
    if not (320 <= w <= 7680 and 240 <= h <= 4320):
        raise argparse.ArgumentTypeError(f"{w}x{h} is out of range (allowed: 320 to 7680 wide, 240 to 4320 high)")
    return w, h


def _screenshot_paths(png: str, times: list[float | None]) -> list[tuple[float | None, str]]:
    """The PNG of each ``--time``: ``png`` itself for one time, else ``png``'s stem with the time added."""
    if len(times) == 1:
        return [(times[0], png)]
    p = pathlib.Path(png)
    return [(t, str(p.with_name(f"{p.stem}_{'end' if t is None else f'{t:g}s'}{p.suffix}"))) for t in times]


def _cmd_replay(args: argparse.Namespace) -> int:
    from excavsim.record import replay

    if args.screenshot is None and (args.time is not None or args.size is not None):
        raise ExcavsimError("--time and --size go with --screenshot PNG (they choose what the headless viewer renders)")
    _check_recording(args.file)
    if args.screenshot is not None:
        from excavsim.record.replay import screenshots

        shots = _screenshot_paths(args.screenshot, args.time or [None])
        if args.dry_run:
            print(f"would render {args.file} headless at {', '.join(f'{t}' for t, _ in shots)} to "
                  f"{', '.join(p for _, p in shots)}")
            return 0
        screenshots(args.file, shots, size=args.size or (1600, 1000))
        return 0
    replay(args.file, dry_run=args.dry_run)
    return 0


def _cmd_regress(args: argparse.Namespace) -> int:
    import json
    import pathlib

    from excavsim.loop.regress import REGRESS_DIR, parse_seeds, run_against, run_regress

    directory = pathlib.Path(args.dir or REGRESS_DIR)
    if args.update and (args.against or args.against_dir):
        raise ExcavsimError("--update rewrites the baseline and --against/--against-dir compare without one: "
                            "give only one of them")
    if args.baseline and (args.against or args.against_dir):
        raise ExcavsimError("--baseline has no meaning with --against/--against-dir (they need no baseline)")
    seeds = parse_seeds(args.seeds) if args.seeds is not None else None
    say = (lambda s: print(s, file=sys.stderr)) if args.json else print  # with --json, stdout is the JSON only
    if args.against or args.against_dir:
        against = args.against or f"the scenarios of {args.against_dir}"
        say(f"excavsim regress: golden scenarios of {directory}, A/B against {against}")
        report = run_against(directory, ref=args.against, against_dir=args.against_dir, only=args.only or None,
                             seeds=seeds, progress=say)
    else:
        baseline = pathlib.Path(args.baseline or directory / "baseline.json")
        say(f"excavsim regress: golden scenarios of {directory} against {baseline}"
            + (" (rewriting it)" if args.update else ""))
        report = run_regress(directory, baseline_path=args.baseline, update=args.update, only=args.only or None,
                             seeds=seeds, progress=say)
    failed = report.failed
    if args.json:
        print(json.dumps(report.to_json(), indent=1, allow_nan=False))
    else:
        print()
        print(report.format(show_seeds=args.all))
    if args.update:
        say(f"baseline written: {baseline}")
        return 0
    if any(c.verdict == "new" for c in report.comparisons):
        say("some scenarios or metrics have no baseline yet: run `excavsim regress --update` and commit it")
    if failed:
        names = ", ".join(f"{c.scenario} {c.metric}" if c.metric != "-" else f"{c.scenario} (missing)"
                          for c in failed)
        print(f"REGRESSION: {len(failed)} metric(s) significantly worse beyond tolerance: {names}", file=sys.stderr)
        return 1
    say("no regression")
    return 0


def _cmd_warmup(args: argparse.Namespace) -> int:
    from excavsim.loop.warmup import warm_up

    warm_up()
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from excavsim.bench import BENCHMARKS, run_benchmarks

    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        raise ExcavsimError(f"unknown benchmark(s) {unknown}; available: {sorted(BENCHMARKS)}")
    run_benchmarks(args.names or None)
    return 0


def _cmd_campaign(args: argparse.Namespace) -> int:
    from excavsim.loop.campaign import load_campaign, run_campaign

    spec = load_campaign(args.campaign)
    out = args.out or f"runs/campaigns/{spec.name}"
    if args.out is None:  # the default, known once the campaign is read: checked as --out would be
        try:
            _out_dir(out)
        except argparse.ArgumentTypeError as exc:
            raise ExcavsimError(f"--out (default): {exc}") from None
    recorder = None
    if args.live is not None:  # records every episode, streams the first of the grid
        from excavsim.loop.campaign import check_campaign
        from excavsim.record.live import LiveRecorders, viewer_url

        first = check_campaign(spec, source=f"campaign {spec.name}")[0].id
        url = viewer_url(args.live or None)
        print(f"streaming episode {first} live to {url}; every episode is recorded (record: true)")
        spec = spec.model_copy(update={"record": True})
        recorder = LiveRecorders(url, first)
    elif spec.record:
        from excavsim.record import RerunRecorder as recorder
    report = run_campaign(spec, out, workers=args.workers, resume=args.resume, ray_address=args.ray,
                          recorder=recorder, progress=print)
    if report.errors:
        print(f"{report.errors} of {len(report.rows)} episodes failed: see their 'error' in {out}/episodes",
              file=sys.stderr)
        return 1
    return 0


def _cmd_learn(args: argparse.Namespace) -> int:
    from excavsim.loop.learn import run_learn

    print(f"excavsim learn: force predictors learned from simulated digs (§5.2); results in {args.out}")
    run_learn(soil=args.soil, digs=args.digs, seed=args.seed, out=args.out, dataset=args.dataset, folds=args.folds,
              split=args.split, compare=args.compare, episodes=args.episodes, dig_budget=args.dig_budget,
              wrist_limit=args.wrist_limit, method=args.method, forgetting=args.forgetting)
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    import pathlib

    from excavsim.loop import calibrate as cal

    if args.table_5_3 and (args.fix or args.brittleness or args.rate_effect):
        raise ExcavsimError("--fix, --brittleness and --rate-effect belong to a record's fit; --table-5-3 identifies "
                            "all of Table 5.3's parameters from DiMaio's own forces")
    if args.brittleness and args.model != "wedge":
        raise ExcavsimError("--brittleness is the wedge model's failure cycle; give it with --model wedge")
    if args.rate_effect and args.model != "wedge":
        raise ExcavsimError("--rate-effect is the wedge model's rate effect on cohesion; give it with --model wedge")
    if args.table_5_3:
        print(f"excavsim calibrate --table-5-3: DiMaio's model identified from its own forces (Table 5.3, Fig. 5.40); "
              f"results in {args.out}")
        cal.table_5_3(args.out, noise_n=args.noise)
        return 0
    if args.record is None:
        raise ExcavsimError("calibrate needs a RECORD (a force data set .npz, .parquet or .csv, or a Rerun "
                            "recording .rrd) or --table-5-3")
    record = pathlib.Path(args.record)
    fixed = cal.parse_fixes(args.model, args.fix)  # refused before any recording or fit
    if args.rrd and not args.record_digs:
        raise ExcavsimError("--rrd FILE records the digs of --record-digs N; give --record-digs too")
    if args.rrd and pathlib.Path(args.rrd).suffix != ".rrd":
        raise ExcavsimError(f"--rrd {shorten(args.rrd)}: a Rerun recording's name ends in .rrd")
    if args.record_digs:
        if record.suffix == ".rrd":
            raise ExcavsimError(f"--record-digs saves a force data set (.npz, .parquet, .csv), not {record.name}; "
                                "record the episode with --rrd FILE as well")
        if record.suffix not in (".npz", ".parquet", ".csv"):
            raise ExcavsimError(f"--record-digs saves RECORD as a force data set: .npz, .parquet or .csv; given "
                                f"{shorten(record.name)}")
        print(f"excavsim calibrate: recording {args.record_digs} digs on the {args.truth} truth into {record}"
              + (f" (and the episode into {args.rrd})" if args.rrd else ""))
        observer = None
        if args.rrd:
            from excavsim.record import RerunRecorder

            observer = RerunRecorder(args.rrd)
        cal.record_digs(record, truth=args.truth, soil=args.soil, digs=args.record_digs, seed=args.seed,
                        quiet=args.quiet, observer=observer, say=print)
    if record.suffix == ".rrd":
        from excavsim.loop.calibrate_digs import recording_dataset
        from excavsim.record.reading import read_recording

        data = recording_dataset(read_recording(record))
        cal.calibrate(data, args.model, args.out, soil=args.soil, rerun_digs=not args.no_rerun, name=record.stem,
                      fixed=fixed, brittleness=args.brittleness, rate_per_decade=args.rate_effect)
    else:
        cal.calibrate(record, args.model, args.out, soil=args.soil, rerun_digs=not args.no_rerun, fixed=fixed,
                      brittleness=args.brittleness, rate_per_decade=args.rate_effect)
    return 0


def _validate_file(kind: str, path: str) -> str:
    """Load the ``kind`` file at ``path`` with every check its use would make; returns what it is.

    Goals are checked against configs/scene.yaml; specifications with their overrides and goal
    resolved; campaigns with every grid value; experiments with every run resolved.

    Raises:
        ConfigError: naming the file, the field and what is allowed.
    """
    from excavsim import config as c

    models = {"robot": c.RobotConfig, "scene": c.SceneConfig, "soils": c.SoilsFile, "sensing": c.SensingConfig,
              "planner": c.PlannerConfig, "executor": c.ExecutorConfig}
    if kind in models:
        return c.load_config(path, models[kind]).__class__.__name__
    if kind == "goal":
        c.check_goal(c.load_trench_goal(path), c.load_scene_config(), source=c.display_path(path))
        return "TrenchGoal"
    if kind == "campaign":
        from excavsim.loop.campaign import load_campaign

        return f"CampaignSpec ({len(load_campaign(path).grid)} grid keys, every value checked)"
    from excavsim.loop.scenario import ResolvedSpec, load_spec

    if kind == "spec":
        spec = load_spec(path)
        try:
            ResolvedSpec(spec)
        except c.ConfigError as exc:
            raise c.ConfigError(f"{c.display_path(path)}: {exc}") from None
        return "EpisodeSpec"
    from excavsim.loop.experiment import ExperimentSpec

    exp = c.load_config(path, ExperimentSpec)
    for run in exp.runs:
        try:
            ResolvedSpec(run)
        except c.ConfigError as exc:
            raise c.ConfigError(f"{c.display_path(path)}: run {shorten(run.name)}: {exc}") from None
    return f"ExperimentSpec ({len(exp.runs)} runs)"


def _cmd_validate(args: argparse.Namespace) -> int:
    print(f"{shorten(args.file, 200)}: valid {_validate_file(args.kind, args.file)}")
    return 0


def _cmd_plan(args: argparse.Namespace) -> int:
    import math
    import pathlib
    import time

    import mujoco
    import numpy as np

    from excavsim import constants
    from excavsim.config import check_goal, get_soil, load_planner_config, load_robot_config, load_scene_config
    from excavsim.handoff.goal import SurfaceProfile
    from excavsim.handoff.maps import ElevationMap
    from excavsim.loop.scenario import resolve_goal
    from excavsim.planning.predictor import WedgePredictor
    from excavsim.planning.search import TrenchPlanner
    from excavsim.robot.extract import arm_from_model
    from excavsim.robot.reachability import load_or_build

    goal = resolve_goal(args.goal or "straight")
    check_goal(goal, load_scene_config(), source=f"--goal {shorten(args.goal or 'straight')}")
    config = load_planner_config(args.planner_config)
    if args.no_volume_constraint:
        config = config.model_copy(update={"volume_constraint": False})
    robot = load_robot_config(args.robot_config)
    soil = get_soil(args.soil)
    if args.map:
        emap, map_label = ElevationMap.load(args.map), args.map
    else:  # the soil box of models/soil_box (3 m square from x = 0.55 m), flat at the 0.5 m fill
        emap = ElevationMap(0.55, -1.5, 0.05, np.full((60, 60), 0.5), np.ones((60, 60), bool), 0.0)
        map_label = "flat 0.5 m fill"
    joints = robot.joints
    wrist = joints.wrist_pitch.torque_limit_nm if args.wrist_limit is None else args.wrist_limit
    limits = np.array([joints.shoulder.torque_limit_nm, joints.elbow.torque_limit_nm, wrist])

    model = mujoco.MjModel.from_xml_path(str(constants.SCENE_XML))
    arm = arm_from_model(model)
    width = float(model.numeric(constants.BUCKET_WIDTH_NUMERIC).data[0])
    capacity = float(model.numeric(constants.BUCKET_CAPACITY_NUMERIC).data[0])
    volume_rule = (f"volume <= {config.fill_fraction:g} x capacity" if config.volume_constraint
                   else "volume constraint off")
    print(f"excavsim plan: trench {goal.name or args.goal!r} on {map_label}, soil {args.soil}, wrist {wrist:.0f} N m, "
          f"objective {config.objective}, {volume_rule}")
    t0 = time.perf_counter()
    table = load_or_build(arm)  # built and cached on first use (a few seconds)
    t_table = time.perf_counter() - t0
    planner = TrenchPlanner(arm, table, limits, width, capacity, goal, config,
                            WedgePredictor(soil, width, capacity_m3=config.heaped_capacity_factor * capacity),
                            soil.density_kg_m3)
    # The figures show every constraint's set over the whole grid, so they need the unpruned search
    # (same answer, slower); without figures the planner searches as the loop does.
    result = planner.plan(emap, prune=args.no_figures, classify_limits=True)

    rows = []
    if result.action is None:
        rows.append(("action", f"none: {result.reason}"))
    else:
        k, alpha, d1, d2 = result.action
        rows.append(("action", f"k {k:.2f} m   alpha {math.degrees(alpha):.1f} deg   d1 {d1:.3f} m   d2 {d2:.3f} m"))
        rows.append(("objective", f"{result.reason} (utility {result.utility:.3f})"))
        rows.append(("volume", f"{1000 * result.volume_m3:.1f} l of {1000 * capacity:.1f} l capacity "
                               f"({100 * result.volume_m3 / capacity:.0f} %)"))
        peaks = np.abs(result.torques).max(axis=0)
        for name, peak, limit in zip(("shoulder", "elbow", "wrist pitch"), peaks, limits):
            rows.append((f"torque {name}", f"peak {peak:7.0f} N m of {limit:7.0f} N m ({100 * peak / limit:3.0f} %)"))
    counts = result.counts
    lim = result.limiting
    n_short, n_none = int(np.sum(result.feasible & (lim == 3))), int(np.sum(~result.feasible & (lim == 2)))
    rows.append(("cells", f"{int(result.feasible.sum())} feasible of {counts['cells']}; evaluated "
                          f"{counts['evaluated']}, pruned along d1 {counts['pruned_d1']}"))
    rows.append(("force-limited", f"{n_short + n_none} cells (Fig. 87): {n_short} feasible with the drag cut short "
                                  f"by the torque limits, {n_none} with no drag within them"))
    search = "pruned search" if args.no_figures else "unpruned: every constraint on every cell, for the figures"
    rows.append(("time", f"planning {result.seconds:.2f} s ({search}); reachability table {t_table:.1f} s"))
    width_col = max(len(r[0]) for r in rows)
    for label, text in rows:
        print(f"  {label:<{width_col}}  {text}")

    if not args.no_figures:
        from excavsim.planning import figures

        out = pathlib.Path(args.out)
        paths = [figures.plot_feasible_sets(result, out / "feasible_sets.png",
                                            min_volume_m3=config.volume_threshold * capacity),
                 figures.plot_limits(result, out / "limits.png")]
        if result.action is not None:
            surface = SurfaceProfile.from_map(emap, arm, math.radians(goal.waist_deg), width)
            paths.append(figures.plot_dig(result, goal, surface, out / "dig.png", torque_limits_nm=limits))
        else:
            print("  (no dig chosen: no dig figure)")
        print("figures:")
        for p in paths:
            print(f"  {p}")
    return 0


def _cmd_experiment(args: argparse.Namespace) -> int:
    import pathlib

    from excavsim.loop.experiment import (experiment_names, format_comparison, format_means, load_experiment,
                                          run_experiment)

    if args.list or not args.names:
        for name in experiment_names():
            print(f"{name}: {load_experiment(name).title}")
        return 0
    names = experiment_names() if args.names == ["all"] else args.names
    specs = [load_experiment(n) for n in names]  # every name checked before anything runs
    if args.dig_budget is not None:
        specs = [s.model_copy(update={"runs": [r.model_copy(update={"dig_budget": args.dig_budget}) for r in s.runs]})
                 for s in specs]
    if args.seeds > 1:  # every run once per seed: seed, then on by the number of runs (fig114's two
        # runs from seeds 0 and 1 get 0, 2, 4, ... and 1, 3, 5, ...: never the same episode twice)
        def reseeded(r, i, stride):
            seed = r.seed + i * stride
            return r.model_copy(update={"seed": seed, "name": f"{r.name}-s{seed}"})

        specs = [s.model_copy(update={"runs": [reseeded(r, i, len(s.runs)) for r in s.runs
                                               for i in range(args.seeds)]}) for s in specs]
    out = pathlib.Path(args.out)
    results = {}
    for exp in specs:
        print(f"excavsim experiment {exp.name}: {exp.title}")
        runs = run_experiment(exp, out / exp.name, progress=print if args.verbose else None)
        results[exp.name] = (exp, runs)
        print((out / exp.name / "summary.txt").read_text())
        print(f"wrote {out / exp.name}/sections.png, digs.csv, digs.txt, summary.txt\n")
    if len(results) > 1 or args.seeds > 1:
        table = format_comparison(results) + "\n\npooled over each experiment's runs:\n" + format_means(results)
        (out / "comparison.txt").write_text(table + "\n")
        print(table)
        print(f"wrote {out / 'comparison.txt'}")
    return 0


def _cmd_tune(args: argparse.Namespace) -> int:
    import math
    import pathlib

    from excavsim.config import get_soil
    from excavsim.loop import truck

    cfg = truck.load_truck_config(args.config)
    retarget = None
    if args.retarget is not None:
        if not 1 <= args.retarget <= args.trials:
            raise ExcavsimError(f"--retarget {args.retarget}: the trial before which the target moves; allowed: 1 to "
                                f"--trials ({args.trials})")
        retarget = (args.retarget - 1, args.retarget_r, math.radians(args.retarget_theta))
    if args.compare:
        if args.record:
            raise ExcavsimError("--record writes one run: leave it out with --compare")
        from excavsim.config import load_scene_config
        from excavsim.loop.truck_campaign import format_table, run_campaign

        soils = args.soils or [args.soil or load_scene_config().soil]
        print(f"excavsim tune --compare: tuned vs untuned{' and a moved target' if retarget else ''}, "
              f"{args.trials} trials, seeds {' '.join(map(str, args.seeds))}, soils {' '.join(soils)} "
              "(001_0de172b0d6b3614b.txt §6.2)")
        runs = run_campaign(seeds=args.seeds, soils=soils, trials=args.trials,
                            retarget=retarget, cfg=cfg, out=pathlib.Path(args.out), progress=print)
        print(format_table(runs, cfg.initial_trials))
        print(f"wrote {pathlib.Path(args.out) / 'truck_campaign.csv'} and truck_campaign.txt")
        return 0
    if args.soil:
        get_soil(args.soil)
    print(f"excavsim tune: {args.trials} truck-loading trials, target r = {cfg.site.r_d} m, theta = "
          f"{math.degrees(cfg.site.theta_d):.1f} deg (001_0de172b0d6b3614b.txt §6.2)")

    def show(t: truck.Trial) -> None:
        print(f"  {t.index + 1:3d} {t.source:16s} cost {truck.trial_cost(t, cfg):8.2f}  time {t.time_s:5.2f} s  "
              f"r {t.pile.r:.3f} m  theta {math.degrees(t.pile.theta):5.1f} deg  {t.outcome}  ({t.wall_s:.2f} s wall)")

    observer = None
    if args.record:
        from excavsim.record.truck import TruckRecorder
        observer = TruckRecorder(args.record, seed=args.seed)
    trials = truck.tune(args.trials, cfg, seed=args.seed, progress=show, retarget=retarget, soil=args.soil,
                        observer=observer)
    csv_path, png = truck.write_results(trials, cfg, pathlib.Path(args.out))
    k = min(cfg.initial_trials, len(trials))
    costs = [truck.trial_cost(t, cfg) for t in trials]
    times = [t.time_s for t in trials]
    err2 = [truck.placement_error2(t, cfg) for t in trials]
    print(f"first {k}: mean cost {sum(costs[:k]) / k:.2f}, time {sum(times[:k]) / k:.2f} s, squared error "
          f"{sum(err2[:k]) / k:.4f} m^2; last {k}: mean cost {sum(costs[-k:]) / k:.2f}, time "
          f"{sum(times[-k:]) / k:.2f} s, squared error {sum(err2[-k:]) / k:.4f} m^2")
    print(f"wrote {csv_path} and {png}")
    if args.record:
        print(f"recorded to {args.record}; replay it with: excavsim replay {args.record}")
    return 0


def _cmd_playback(args: argparse.Namespace) -> int:
    import pathlib

    from excavsim.execution.demonstration import load_demonstration
    from excavsim.loop import playback

    out = pathlib.Path(args.out)
    modes = [name for name, on in (("--teleop", args.teleop), ("--from-rrd", args.from_rrd), ("--demo", args.demo))
             if on]
    if len(modes) > 1:
        raise ExcavsimError(f"playback: {' and '.join(modes)} cannot be combined; give one of --teleop, --from-rrd "
                            f"FILE.rrd, --demo FILE.json (or none for the chapter-6 experiment)")
    if args.keys is not None and not args.teleop:
        raise ExcavsimError("playback: --keys is the key sequence of --teleop; give --teleop with it")
    if args.dig is not None and not args.from_rrd:
        raise ExcavsimError("playback: --dig chooses the dig of --from-rrd FILE.rrd; give --from-rrd with it")
    if (args.live is not None or args.record) and not args.teleop:
        raise ExcavsimError("playback: --live and --record show or record a --teleop session; give --teleop with them")
    if args.record and not args.record.endswith(".rrd"):
        raise ExcavsimError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    seeds = None
    if args.seeds is not None:
        if args.teleop or args.from_rrd or args.seed is not None:
            raise ExcavsimError("playback: --seeds runs the chapter-6 experiment on several seeds; it cannot be "
                                "combined with --seed, --teleop or --from-rrd (give --seeds alone, or with --demo)")
        seeds = playback.seed_range(args.seeds)
    seed = args.seed if args.seed is not None else 0
    if args.teleop:
        from excavsim.execution.teleop import HELP
        from excavsim.loop import teleop

        keys = args.keys if args.keys is not None else teleop.tty_keys()
        observer = None
        if args.record or args.live is not None:
            from excavsim.record import RerunRecorder
            from excavsim.record.live import viewer_url

            live = viewer_url(args.live or None) if args.live is not None else None
            if live:
                print(f"streaming the session live to {live}")
            observer = RerunRecorder(args.record, live=live)
        print(f"excavsim playback --teleop: drive the bucket tip from 10 cm above the demonstration dig; {HELP}")
        demo = teleop.teleoperate(keys, seed=seed, observer=observer, on_key=lambda k, p, f: print(
            f"{k}: tip x {p[0]:.2f} m z {p[1]:.2f} m pitch {math.degrees(p[2]):.0f} deg | F radial {f[0]:7.0f} N "
            f"vertical {f[1]:7.0f} N", flush=True))
        if args.record:
            print(f"recorded to {args.record}; replay it with: excavsim replay {args.record}")
        out.mkdir(parents=True, exist_ok=True)
        path = demo.save(out / "teleop_demonstration.json")
        print(f"wrote {path} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); play it back with: "
              f"excavsim playback --demo {path}")
        return 0
    if args.from_rrd:
        from excavsim.record.demo_reading import read_dig

        dig = read_dig(args.from_rrd, args.dig or 1)
        demo = playback.demonstration_from_signals(dig.joint_times, dig.joints, dig.ft_times, dig.ft_tip,
                                                   dig.path_world, source=f"{args.from_rrd}, dig {dig.dig}")
        out.mkdir(parents=True, exist_ok=True)
        path = demo.save(out / "rrd_demonstration.json")
        print(f"wrote {path}: dig {dig.dig} of {args.from_rrd} ({len(demo.times)} samples, {demo.times[-1]:.2f} s); "
              f"play it back with: excavsim playback --demo {path}")
        return 0
    print("excavsim playback: demonstrate a dig, replay it in a stiffer and a softer soil with fixed high, moderate, "
          "low and variable impedance (002_694c274da322d931.txt §3.3, ch. 6)")
    demo = load_demonstration(args.demo) if args.demo else None
    if seeds is not None:
        print(f"over seeds {', '.join(map(str, seeds))}: each seed records its own demonstration"
              + (" (here: the given one)" if demo is not None else "") + " and replays it in worlds of that seed")
        playback.run_seeds(seeds, out, sweep=not args.no_sweep, demo=demo)
        return 0
    playback.run_playback(out, seed=seed, sweep=not args.no_sweep, demo=demo)
    return 0


def _cmd_load(args: argparse.Namespace) -> int:
    import pathlib

    from excavsim.loop import loading as ld

    cfg = ld.load_loading_config(args.config)
    if args.mujoco or args.campaign:
        return _load_mujoco(args, cfg)
    if args.record:
        raise ExcavsimError("--record needs --mujoco (the 2-D simulation writes figures to --out)")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    u = cfg.units_m2
    if args.study:
        print(f"excavsim load --study: Fig. 112, {args.runs or cfg.study.runs} runs per force limit and machine, "
              f"each removing {cfg.study.remove_units:.0f} units from a random pile")
        res = ld.study(args.config, runs=args.runs, workers=args.workers, seed=args.seed)
        table = ld.format_study(res)
        (out / "fig112.txt").write_text(table + "\n")
        ld.figure_study(res, out / "fig112.png")
        print(table)
        print(f"wrote {out / 'fig112.png'}, {out / 'fig112.txt'}")
        return 0
    names = [args.machine] if args.machine else list(ld.MACHINES)
    rows, paths = [], []
    plans = {}
    for name in ld.MACHINES:
        spec = getattr(cfg.machines, name)
        plans[name] = ld.lp.plan(ld.make_machine(cfg, name), ld.terrain_of(ld.make_pile(cfg)),
                                 ld.make_rules(cfg, spec.capacity_units))
    ld.figure_constraints(plans, out / "constraints.png")
    paths.append(out / "constraints.png")
    runs = [(n, False) for n in names] + ([("loader", True)] if "loader" in names else [])
    for name, force in runs:
        fig, key = {("loader", False): ("fig108", "loader"), ("shovel", False): ("fig109", "shovel"),
                    ("loader", True): ("fig111", "loader_force")}[(name, force)]
        label = f"{fig} front {name}" + (f", force <= {cfg.fig111_force_limit_kn_m:g} kN/m" if force else "")
        print(f"{label}:")
        run = ld.run_machine(cfg, name, force=force)
        spec = getattr(cfg.machines, name)
        rules = ld.make_rules(cfg, spec.capacity_units, cfg.fig111_force_limit_kn_m if force else None)
        print(ld.format_run(run, u, rules.exit_heading))
        ld.figure_sequence(run, ld.make_machine(cfg, name), rules, cfg.pile.dx, out / f"{fig}.png", label)
        (out / f"{fig}.txt").write_text(ld.format_run(run, u, rules.exit_heading) + "\n")
        paths += [out / f"{fig}.png", out / f"{fig}.txt"]
        rows.append((label, run, ld.THESIS[key]))
    table = ld.format_comparison(rows, u)
    (out / "comparison.txt").write_text(table + "\n")
    print("\nbeside the thesis (§7.2.1; 1 unit of soil = %g m^2 of the section):" % u)
    print(table)
    print("wrote " + ", ".join(str(p) for p in paths + [out / "comparison.txt"]))
    return 0


def _load_mujoco(args: argparse.Namespace, cfg) -> int:
    """``excavsim load --mujoco``: a loading episode per machine in MuJoCo (excavsim.loop.loading_mujoco)."""
    from excavsim.loop import loading_mujoco as lm

    if args.study:
        raise ExcavsimError("--study is the 2-D simulation's (Fig. 112); --mujoco runs single episodes")
    if args.campaign:
        if args.record or args.machine:
            raise ExcavsimError("--campaign runs the machines and seeds its file names; --record and --machine "
                                "are single episodes' options")
        import pathlib

        spec = lm.load_campaign(args.campaign)
        mcfg = lm.load_mujoco_config(args.mujoco_config or spec.mujoco_config)
        print(f"excavsim load --campaign: {', '.join(spec.machines)} x seeds {spec.seeds} in MuJoCo, pile "
              f"{mcfg.pile.height:g} m high, soil {mcfg.soil}")
        rows = lm.run_campaign(spec, cfg=mcfg, cfg2d=cfg, progress=print)
        two_d = {name: lm.same_pile_2d(name, mcfg, cfg) for name in spec.machines}
        table = lm.format_campaign(rows, two_d, cfg.units_m2)
        out = pathlib.Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "campaign.txt").write_text(table + "\n")
        print(table)
        print(f"wrote {out / 'campaign.txt'}")
        return 0 if all(r.done for _, _, r in rows) else 1
    if args.record and not args.record.endswith(".rrd"):
        raise ExcavsimError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    mcfg = lm.load_mujoco_config(args.mujoco_config)
    names = [args.machine] if args.machine else list(lm.MACHINES)
    if args.record and len(names) > 1:
        raise ExcavsimError("--record writes one episode: give --machine loader or --machine shovel with it")
    rows = []
    for name in names:
        print(f"excavsim load --mujoco: front {name}, pile {mcfg.pile.height:g} m high, soil {mcfg.soil}, "
              f"seed {args.seed}")
        observer = None
        if args.record:
            from excavsim.record.loading import LoadingRecorder

            observer = LoadingRecorder(args.record)
        run = lm.run_episode(name, seed=args.seed, cfg=mcfg, cfg2d=cfg, observer=observer, progress=print)
        print(lm.format_run(run))
        rows.append((name, run))
        if args.record:
            print(f"recorded to {args.record}")
    if len(rows) > 1:
        print("\n" + lm.format_comparison(rows))
    return 0 if all(r.done for _, r in rows) else 1


def _cmd_figures(args: argparse.Namespace) -> int:
    from excavsim.loop import figures

    table = figures.figures()
    if args.list:
        for name, fig in table.items():
            print(f"  {name}  {fig.title}")
        return 0
    names = figures.check_names(args.names)
    print(f"excavsim figures: {len(names)} figure(s) of Singh's thesis into {args.out}")
    figures.write_figures(names, args.out, seed=args.seed, progress=print)
    return 0


def _world_options(parser: argparse.ArgumentParser) -> None:
    """The options of every command that builds a Simulation: configurations and the episode seed."""
    parser.add_argument("--robot-config", metavar="YAML", help="servo configuration (default configs/robot.yaml)")
    parser.add_argument("--scene-config", metavar="YAML", help="scene configuration (default configs/scene.yaml)")
    parser.add_argument("--seed", type=_seed, default=0, help=f"episode seed (soil, sensor noise, scanner drift; "
                        f"0 to {MAX_SEED})")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``excavsim`` command."""
    from excavsim import __version__

    parser = argparse.ArgumentParser(prog="excavsim", description="MuJoCo testbed for robotic trenching.")
    parser.add_argument("--version", action="version", version=f"excavsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="one hand-picked dig through the loop: scan, dig, dump, settle, scan")
    _world_options(demo)
    demo.set_defaults(func=_cmd_demo)

    trench = sub.add_parser("trench", help="dig a trench: scan, plan, dig, settle until done or out of digs")
    trench.add_argument("--spec", metavar="YAML", help="an episode specification (goal, soil, seed, budget, "
                                                       "configuration overrides; e.g. configs/regress/small_sand.yaml)")
    trench.add_argument("--goal", metavar="NAME|YAML", type=_name_or_path,
                        help="trench goal: a name of configs/trenches (sand, straight, small) or a YAML file "
                             "(default sand)")
    trench.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default: the scene's)")
    trench.add_argument("--dig-budget", type=_dig_budget, metavar="N",
                        help=f"most digs to try (1 to {MAX_DIG_BUDGET}, default 20)")
    trench.add_argument("--record", metavar="FILE.rrd", type=_out_file(()),
                        help="record the episode to a Rerun file (see `replay`)")
    trench.add_argument("--live", nargs="?", const="", metavar="ADDRESS",
                        help="stream the episode to a Rerun viewer as it runs: alone, spawn one (needs a display); "
                             "with PORT, HOST:PORT or rerun+http://HOST:PORT/proxy, a running viewer (`rerun`)")
    trench.add_argument("--save-maps", metavar="DIR", type=_out_dir,
                        help="save every scanned elevation map (for `plan --map`)")
    trench.add_argument("--robot-config", metavar="YAML", help="servo configuration (default configs/robot.yaml)")
    trench.add_argument("--scene-config", metavar="YAML", help="scene configuration (default configs/scene.yaml)")
    trench.add_argument("--seed", type=_seed, help=f"episode seed (0 to {MAX_SEED}, default 0)")
    trench.set_defaults(func=_cmd_trench)

    replay = sub.add_parser("replay", help="open a recorded episode (.rrd) in the Rerun viewer")
    replay.add_argument("file", metavar="FILE.rrd",
                        help="a recording written by `excavsim trench --record` (checked with `rerun rrd verify`)")
    replay.add_argument("--dry-run", action="store_true", help="only print the viewer command")
    replay.add_argument("--screenshot", metavar="PNG", type=_out_file((".png",)),
                        help="render headless instead of opening a window, and write PNG (needs Vulkan: a GPU "
                             "driver or, without one, Debian's mesa-vulkan-drivers)")
    replay.add_argument("--time", nargs="+", type=_sim_time, metavar="T",
                        help="simulated times [s] (or 'end', the default) of the screenshots; with several, "
                             "PNG's name gets the time added (shot_20s.png)")
    replay.add_argument("--size", type=_window_size, metavar="WxH",
                        help="the headless viewer's size in points (default 1600x1000)")
    replay.set_defaults(func=_cmd_replay)

    cycle = sub.add_parser("cycle", help="one cycle of the loop: an episode of one dig of the default trench")
    _world_options(cycle)
    cycle.set_defaults(func=_cmd_cycle)

    regress = sub.add_parser(
        "regress", help="run the golden scenarios over several seeds and judge their metrics statistically, "
                        "against the committed baseline or (A/B) against a git ref")
    regress.add_argument("--dir", metavar="DIR", help="scenario directory (default configs/regress)")
    regress.add_argument("--baseline", metavar="JSON", help="baseline file (default DIR/baseline.json)")
    regress.add_argument("--update", action="store_true", help="rewrite the baseline from this run")
    regress.add_argument("--only", nargs="*", metavar="NAME", help="run only these scenarios (file stems)")
    regress.add_argument("--seeds", metavar="N|A-B|a,b,c",
                         help="seeds of every scenario: a count from its seed, a range or a list "
                              "(default: each file's seeds, 8 unless it says)")
    ab = regress.add_mutually_exclusive_group()
    ab.add_argument("--against", metavar="REF",
                    help="A/B: run the same scenarios and seeds with the code at git REF (a temporary worktree) "
                         "and with the working tree; compare paired by seed, no baseline needed")
    ab.add_argument("--against-dir", metavar="DIR2",
                    help="A/B: compare with the same-named scenarios of DIR2 (e.g. another planner configuration)")
    regress.add_argument("--all", action="store_true", help="also print every seed's values")
    regress.add_argument("--json", action="store_true",
                         help="print the result as JSON on stdout (progress goes to stderr)")
    regress.set_defaults(func=_cmd_regress)

    warm = sub.add_parser("warmup", help="compile every numba kernel into the cache (make runs it after installing), "
                                          "so the first run starts warm")
    warm.set_defaults(func=_cmd_warmup)

    bench = sub.add_parser("bench", help="run benchmarks and print one table of numbers and ratios")
    bench.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (default: all)")
    bench.set_defaults(func=_cmd_bench)

    campaign = sub.add_parser("campaign", help="run a grid of trenching episodes in parallel; summary table and plots")
    campaign.add_argument("campaign", metavar="CAMPAIGN.yaml",
                          help="campaign file (e.g. configs/campaigns/example.yaml)")
    campaign.add_argument("--out", metavar="DIR", type=_out_dir, help="output directory (default runs/campaigns/NAME)")
    campaign.add_argument("--workers", type=_int_in(1, 1024), metavar="N",
                          help="parallel processes (1 to 1024, default: the CPU count)")
    campaign.add_argument("--resume", action="store_true", help="run only the episodes that have no result in DIR")
    campaign.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                          help="run on Ray: alone for a local instance, or 'auto' / HOST:PORT for a running cluster "
                               "(pip install 'excavsim[ray]')")
    campaign.add_argument("--live", nargs="?", const="", metavar="ADDRESS",
                          help="stream the grid's first episode to a Rerun viewer as it runs (spawned, or the one at "
                               "ADDRESS, as trench --live); records every episode")
    campaign.set_defaults(func=_cmd_campaign)

    validate = sub.add_parser("validate", help="check a configuration file and report every problem")
    validate.add_argument("kind", choices=VALIDATE_KINDS,
                          help="what the file configures (goal: a trench goal, checked against configs/scene.yaml; "
                               "spec: an episode specification with its overrides and goal; campaign and "
                               "experiment: every episode they make)")
    validate.add_argument("file", help="the YAML file")
    validate.set_defaults(func=_cmd_validate)

    plan = sub.add_parser("plan", help="plan one dig of a trench on an elevation map, print it and draw figures")
    plan.add_argument("--goal", metavar="NAME|YAML", type=_name_or_path,
                      help="trench goal: a name of configs/trenches or a YAML file (default straight)")
    plan.add_argument("--map", metavar="NPZ", help="elevation map written by excavsim (default: flat 0.5 m sand)")
    plan.add_argument("--planner-config", metavar="YAML", help="planner configuration (default configs/planner.yaml)")
    plan.add_argument("--robot-config", metavar="YAML", help="torque limits (default configs/robot.yaml)")
    plan.add_argument("--soil", metavar="NAME", default="testbed_sand",
                      help="soil preset of configs/soils.yaml the force predictor assumes (default testbed_sand)")
    plan.add_argument("--wrist-limit", metavar="NM", type=_float_in(10, 1e6),
                      help="wrist pitch torque limit [N m] (10 to 1e6; default: the robot configuration's)")
    plan.add_argument("--out", metavar="DIR", default="runs/plan", type=_out_dir,
                      help="where the figures go (default runs/plan)")
    plan.add_argument("--no-volume-constraint", action="store_true",
                      help="switch the volume constraint off: only the force constraint bounds how much a dig "
                           "sweeps (§7.2.2, Figs. 115-117; the setting of the Fig. 87 comparison)")
    plan.add_argument("--no-figures", action="store_true", help="only print the plan (pruned search, faster)")
    plan.set_defaults(func=_cmd_plan)

    exp = sub.add_parser("experiment", help="run the thesis' trenching experiments (Figs. 113-117): section "
                                            "figures, dig tables, summaries")
    exp.add_argument("names", nargs="*", metavar="NAME",
                     help="experiments of configs/experiments (fig113 ... fig117), YAML files, or 'all'; "
                          "none: list them")
    exp.add_argument("--list", action="store_true", help="list the experiments and exit")
    exp.add_argument("--out", metavar="DIR", default="runs/experiments", type=_out_dir,
                     help="output directory, one subdirectory per experiment (default runs/experiments)")
    exp.add_argument("--dig-budget", type=_dig_budget, metavar="N",
                     help=f"override every run's dig budget (1 to {MAX_DIG_BUDGET})")
    exp.add_argument("--seeds", type=_int_in(1, 1000), default=1, metavar="N",
                     help="run every run with N seeds (its own, then the next N - 1) and pool them (default 1)")
    exp.add_argument("--verbose", action="store_true", help="print every scan and dig")
    exp.set_defaults(func=_cmd_experiment)

    learn = sub.add_parser("learn", help="learn to predict soil forces: data from digs, Tables 4-5, Fig. 81, "
                                         "nominal vs learned in the loop")
    learn.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default: the scene's)")
    learn.add_argument("--digs", type=_int_in(1, 100_000), default=30, metavar="N",
                       help="digs to collect (default 30)")
    learn.add_argument("--seed", type=_seed, default=0, metavar="N", help="seeds the soil beds, actions and folds")
    learn.add_argument("--out", metavar="DIR", default="runs/learn", type=_out_dir,
                       help="output directory (default runs/learn)")
    learn.add_argument("--dataset", metavar="FILE", type=_out_file((".parquet", ".csv", ".npz")),
                       help="force data set (.parquet, .csv, .npz): loaded if it exists, else built and saved there")
    learn.add_argument("--folds", type=_int_in(2, 1000), default=10, metavar="N",
                       help="cross-validation folds (default 10)")
    learn.add_argument("--split", choices=["samples", "digs", "both"], default="both",
                       help="cross-validate over shuffled samples (the thesis), whole digs, or both (default)")
    learn.add_argument("--compare", action="store_true",
                       help="also run episodes planned with the nominal wedge model and with learned predictors")
    learn.add_argument("--episodes", type=_int_in(1, 1000), default=2, metavar="N",
                       help="episodes per predictor (default 2)")
    learn.add_argument("--dig-budget", type=_dig_budget, default=6, metavar="N", help="digs per episode (default 6)")
    learn.add_argument("--wrist-limit", type=_float_in(10, 1e6), metavar="NM",
                       help="wrist pitch torque limit in the comparison [N m] (default: configs/robot.yaml)")
    learn.add_argument("--method", default="global", metavar="NAME",
                       help="learned predictor in the comparison: global, global_rls, nn3, lwr, lwr_scaled, net")
    learn.add_argument("--forgetting", type=_float_in(0, 1, low_open=True), default=1.0, metavar="F",
                       help="forgetting factor of eq. 22 for a global regression in the comparison (default 1)")
    learn.set_defaults(func=_cmd_learn)

    calib = sub.add_parser("calibrate", help="fit a soil (wedge or DiMaio) to a force record; Table 5.3's "
                                             "identification experiment")
    calib.add_argument("record", nargs="?", metavar="RECORD",
                       help="force data set of digs (.npz, .parquet, .csv; `learn --dataset` or --record-digs "
                            "writes one) or a Rerun recording of an episode (.rrd: its F/T, joint angles, scans "
                            "and plans are read)")
    calib.add_argument("--model", choices=["wedge", "dimaio"], default="wedge",
                       help="the model whose soil parameters are fitted (default wedge)")
    calib.add_argument("--out", metavar="DIR", default="runs/calibrate", type=_out_dir,
                       help="output directory (default runs/calibrate)")
    calib.add_argument("--fix", action="append", metavar="NAME=VALUE",
                       help="hold a parameter of --model's fit at VALUE and fit the rest (repeatable); wedge: "
                            "c_pa (or cohesion_pa), phi_deg, delta_deg, gamma_n_m3, e.g. cohesion_pa=0 for a "
                            "cohesionless sand; dimaio: b_t0, b_n0, mu, eps, rho, k, T_rt, T_rn, S")
    calib.add_argument("--soil", metavar="NAME", help="preset the fit starts from and the YAML completes "
                                                      "(default: the record's)")
    calib.add_argument("--record-digs", type=_int_in(1, 1000), metavar="N",
                       help="first dig N random feasible digs in simulation and save their record as RECORD")
    calib.add_argument("--truth", choices=["wedge", "dimaio"], default="wedge",
                       help="the world's force model for --record-digs (default wedge)")
    calib.add_argument("--brittleness", type=_float_in(0, 1, high_open=True), default=0.0, metavar="I_B",
                       help="the wedge's failure cycle: the share of the failure force lost at each failure, "
                            "which the record model averages over (default 0: eq. 8's crest, a quiet record; "
                            "0.2 for a record of the default world, scene.yaml truth.brittleness_index)")
    calib.add_argument("--rate-effect", type=_float_in(0, 1), default=0.0, metavar="A",
                       help="the wedge's rate effect on cohesion: c rises by A per tenfold advance speed above "
                            "0.01 m/s, so that the fitted c is the strength at 0.01 m/s as a preset's (default 0: "
                            "the strength at the digs' rate; 0.1 for a clay of the default world, scene.yaml "
                            "truth.cohesion_rate_per_decade)")
    calib.add_argument("--quiet", action="store_true",
                       help="with --record-digs: the wedge's rate effect, failure-cycle drops, heterogeneity and "
                            "the F/T's digging disturbance off")
    calib.add_argument("--seed", type=_seed, default=0, metavar="N", help="seed of --record-digs")
    calib.add_argument("--rrd", metavar="FILE", help="with --record-digs: also record the episode to this Rerun "
                                                     "recording (calibrate it with `excavsim calibrate FILE`)")
    calib.add_argument("--no-rerun", action="store_true",
                       help="skip re-running the recorded digs in simulation with the fitted soils")
    calib.add_argument("--table-5-3", action="store_true",
                       help="reproduce Table 5.3 and Fig. 5.40 (DiMaio's model identified from its own forces)")
    calib.add_argument("--noise", type=_float_in(0, 1e4), default=5.0, metavar="N",
                       help="F/T noise of --table-5-3 per axis [N] (default 5, the scene's)")
    calib.set_defaults(func=_cmd_calibrate)

    load = sub.add_parser("load", help="loading from a pile in a 2-D world (§7.2.1, Figs. 108-112): front loader "
                                       "and front shovel, the action space's constraints (Figs. 28-35)")
    load.add_argument("--machine", choices=["loader", "shovel"],
                      help="one machine (default both; the loader also with the force constraint, Fig. 111)")
    load.add_argument("--study", action="store_true",
                      help="Fig. 112: efficiency against the force limit, random piles, both machines")
    load.add_argument("--runs", type=_int_in(1, 1000), metavar="N", help="runs per force limit in --study "
                      "(default configs/loading.yaml's, 20)")
    load.add_argument("--workers", type=_int_in(1, 64), default=1, metavar="N", help="processes for --study")
    load.add_argument("--seed", type=_seed, default=0, metavar="N",
                      help="the first random pile's seed (--study); the episode's (--mujoco)")
    load.add_argument("--config", metavar="YAML", help="loading configuration (default configs/loading.yaml)")
    load.add_argument("--out", metavar="DIR", default="runs/load", type=_out_dir,
                      help="output directory (default runs/load)")
    load.add_argument("--mujoco", action="store_true",
                      help="a loading episode in MuJoCo instead: the MJCF loader/shovel beside a pile lane, the "
                           "world's soil and scanner, the planner, a joint-space script per dig, settlement")
    load.add_argument("--mujoco-config", metavar="YAML",
                      help="with --mujoco: its configuration (default configs/loading_mujoco.yaml)")
    load.add_argument("--record", metavar="FILE.rrd", type=_out_file(()),
                      help="with --mujoco and --machine: record the episode to a Rerun file")
    load.add_argument("--campaign", metavar="YAML", type=_name_or_path,
                      help="MuJoCo episodes of each machine over seeds, judged together (e.g. "
                           "configs/campaigns/loading_mujoco.yaml); writes campaign.txt to --out")
    load.set_defaults(func=_cmd_load)
    tune = sub.add_parser("tune", help="truck loading by the mass-excavation script, self-tuned online by "
                          "memory-based learning (001_0de172b0d6b3614b.txt §6.2): the learning curve of Fig. 12")
    tune.add_argument("--trials", type=_int_in(1, 10000), default=40, metavar="N", help="trials (default 40)")
    tune.add_argument("--seed", type=_seed, default=0, metavar="N", help="the world's seed (default 0)")
    tune.add_argument("--config", metavar="YAML", help="truck configuration (default configs/truck.yaml)")
    tune.add_argument("--out", metavar="DIR", default="runs/tune", type=_out_dir,
                      help="output directory (default runs/tune)")
    tune.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default the scene's)")
    tune.add_argument("--record", metavar="FILE.rrd", type=_out_file((".rrd",)),
                      help="record the trials to Rerun (the target, the pile, the script's phases)")
    tune.add_argument("--retarget", type=_int_in(1, 10000), metavar="K",
                      help="move the dump target before trial K (1-based)")
    tune.add_argument("--retarget-r", type=_float_in(0.5, 3.0), default=1.6, metavar="M",
                      help="the moved target's radius [m] (default 1.6)")
    tune.add_argument("--retarget-theta", type=_float_in(-90.0, 90.0), default=45.0, metavar="DEG",
                      help="the moved target's angle [deg] (default 45)")
    tune.add_argument("--compare", action="store_true",
                      help="the campaign: tuned vs untuned (and the moved target with --retarget) over --seeds and "
                           "--soils; writes truck_campaign.csv and .txt to --out")
    tune.add_argument("--seeds", type=_seed, nargs="+", default=[0, 1, 2], metavar="N",
                      help="seeds of --compare (default 0 1 2)")
    tune.add_argument("--soils", nargs="+", metavar="NAME", help="soil presets of --compare (default the scene's)")
    tune.set_defaults(func=_cmd_tune)
    pb = sub.add_parser("playback", help="programming digs by demonstration: replay a demonstrated dig in a stiffer "
                        "and a softer soil with fixed and variable impedance (DiMaio ch. 3, 6)")
    pb.add_argument("--seed", type=_seed, default=None, metavar="N", help="the worlds' seed (default 0)")
    pb.add_argument("--seeds", metavar="SPEC", help="run the experiment on several seeds ('0-7', '0,2,5') and print "
                    "each soil's and controller's errors per seed and their mean; writes DIR/seeds.csv")
    pb.add_argument("--no-sweep", action="store_true", help="skip the velocity-weighting sweep (Figs. 6.46-6.48)")
    pb.add_argument("--teleop", action="store_true", help="make a demonstration by teleoperation from the terminal "
                    "(keys a/d w/s q/e move the tip, x finishes); writes DIR/teleop_demonstration.json")
    pb.add_argument("--keys", metavar="SEQUENCE", help="with --teleop: the keys as a string instead of the terminal")
    pb.add_argument("--live", nargs="?", const="", metavar="ADDRESS", help="with --teleop: stream the session to a "
                    "Rerun viewer (the F/T plot shows the force while driving); alone, spawn one (needs a display)")
    pb.add_argument("--record", metavar="FILE.rrd", type=_out_file(()),
                    help="with --teleop: record the session to a Rerun file")
    pb.add_argument("--from-rrd", metavar="FILE.rrd", help="make a demonstration from a dig of a Rerun recording "
                    "(excavsim trench --record); writes DIR/rrd_demonstration.json")
    pb.add_argument("--dig", type=_int_in(1, 100_000), metavar="N", help="with --from-rrd: which dig (default 1)")
    pb.add_argument("--demo", metavar="FILE.json", help="play back this demonstration file instead of recording one")
    pb.add_argument("--out", metavar="DIR", default="runs/playback", type=_out_dir,
                    help="output directory (default runs/playback)")
    pb.set_defaults(func=_cmd_playback)
    figs = sub.add_parser("figures", help="redraw the thesis' figures (Figs. 20-91: soil forces in the world beside "
                          "the static wedge model, rotation centres, torques, feasible sets, planning time) as PNGs")
    figs.add_argument("names", nargs="*", metavar="NAME", help="figures to draw, e.g. fig54 fig59 (default: all; "
                      "see --list)")
    figs.add_argument("--list", action="store_true", help="list the figures and exit")
    figs.add_argument("--out", metavar="DIR", default="runs/figures", type=_out_dir,
                      help="output directory, one NAME.png per figure (default runs/figures)")
    figs.add_argument("--seed", type=_seed, default=0, metavar="N",
                      help="the worlds' seed (Fig. 59 also uses the next two; default 0)")
    figs.set_defaults(func=_cmd_figures)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse has printed its message (status 2) or the help (status 0)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    try:
        return args.func(args)
    except ExcavsimError as exc:  # every line cut short: a message never repeats a huge input whole
        text = "\n".join(shorten(line, 400) for line in str(exc).splitlines()[:50])
        print(f"excavsim: error: {text}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("excavsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
