"""The study commands: ``campaign`` (a grid of episodes), ``regress`` (the golden scenarios),
``experiment`` (the thesis' trenching experiments), ``learn`` (force predictors), ``figures`` (the
thesis' figures) and ``bench``."""

from __future__ import annotations

import argparse
import pathlib
import sys

from excavsim.cli.live import live_stream
from excavsim.config.arguments import MAX_DIG_BUDGET, dig_budget_type, float_in, int_in, out_dir, out_file, seed_type
from excavsim.errors import ConfigError, UsageError


def _cmd_regress(args: argparse.Namespace) -> int:
    import json

    from excavsim.studies.regress.suite import REGRESS_DIR, parse_seeds, run_against, run_regress

    directory = pathlib.Path(args.dir or REGRESS_DIR)
    if args.update and (args.against or args.against_dir):
        raise UsageError("--update rewrites the baseline and --against/--against-dir compare without one: "
                         "give only one of them")
    if args.baseline and (args.against or args.against_dir):
        raise UsageError("--baseline has no meaning with --against/--against-dir (they need no baseline)")
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



def _cmd_bench(args: argparse.Namespace) -> int:
    from excavsim.studies.bench import BENCHMARKS, run_benchmarks

    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        raise ConfigError(f"unknown benchmark(s) {unknown}; available: {sorted(BENCHMARKS)}")
    run_benchmarks(args.names or None)
    return 0


def _cmd_campaign(args: argparse.Namespace) -> int:
    from excavsim.studies.campaign.runner import load_campaign, run_campaign

    spec = load_campaign(args.campaign)
    out = args.out or f"runs/campaigns/{spec.name}"
    if args.out is None:  # the default, known once the campaign is read: checked as --out would be
        try:
            out_dir(out)
        except argparse.ArgumentTypeError as exc:
            raise ConfigError(f"--out (default): {exc}") from None
    with live_stream(args.live) as url:  # a viewer window that --live spawns ends with the command
        live = None
        if url is not None:  # records every episode, streams the first of the grid
            from excavsim.studies.campaign.runner import check_campaign

            first = check_campaign(spec, source=f"campaign {spec.name}")[0].id
            print(f"streaming episode {first} live to {url}; every episode is recorded (record: true)")
            spec = spec.model_copy(update={"record": True})
            live = (url, first)
        report = run_campaign(spec, out, workers=args.workers, resume=args.resume, ray_address=args.ray, live=live,
                              progress=print)
        if report.errors:
            print(f"{report.errors} of {len(report.rows)} episodes failed: see their 'error' in {out}/episodes",
                  file=sys.stderr)
    return 1 if report.errors else 0


def _cmd_learn(args: argparse.Namespace) -> int:
    from excavsim.studies.learning.compare import run_learn

    print(f"excavsim learn: force predictors learned from simulated digs (§5.2); results in {args.out}")
    run_learn(soil=args.soil, digs=args.digs, seed=args.seed, out=args.out, dataset=args.dataset, folds=args.folds,
              split=args.split, compare=args.compare, episodes=args.episodes, dig_budget=args.dig_budget,
              wrist_limit=args.wrist_limit, method=args.method, forgetting=args.forgetting)
    return 0



def _cmd_experiment(args: argparse.Namespace) -> int:
    from excavsim.studies.experiment import experiment_names, load_experiment, run_experiments

    if args.list or not args.names:
        for name in experiment_names():
            print(f"{name}: {load_experiment(name).title}")
        return 0
    run_experiments(args.names, args.out, dig_budget=args.dig_budget, seeds=args.seeds, verbose=args.verbose)
    return 0


def _cmd_figures(args: argparse.Namespace) -> int:
    from excavsim.studies.figures import thesis as figures

    table = figures.figures()
    if args.list:
        for name, fig in table.items():
            print(f"  {name}  {fig.title}")
        return 0
    names = figures.check_names(args.names)
    print(f"excavsim figures: {len(names)} figure(s) of Singh's thesis into {args.out}")
    figures.write_figures(names, args.out, seed=args.seed, progress=print)
    return 0



def register(sub: argparse._SubParsersAction) -> None:
    """Add the study commands to ``sub``."""
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

    bench = sub.add_parser("bench", help="run benchmarks and print one table of numbers and ratios")
    bench.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (default: all)")
    bench.set_defaults(func=_cmd_bench)

    campaign = sub.add_parser("campaign", help="run a grid of episodes of any tasks in parallel; summary table and plots")
    campaign.add_argument("campaign", metavar="CAMPAIGN.yaml",
                          help="campaign file (e.g. configs/campaigns/example.yaml)")
    campaign.add_argument("--out", metavar="DIR", type=out_dir, help="output directory (default runs/campaigns/NAME)")
    campaign.add_argument("--workers", type=int_in(1, 1024), metavar="N",
                          help="parallel processes (1 to 1024, default: the CPU count)")
    campaign.add_argument("--resume", action="store_true", help="run only the episodes that have no result in DIR")
    campaign.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                          help="run on Ray: alone for a local instance, or 'auto' / HOST:PORT for a running cluster "
                               "(pip install 'excavsim[ray]')")
    campaign.add_argument("--live", nargs="?", const="", metavar="ADDRESS",
                          help="stream the grid's first episode to a Rerun viewer as it runs (spawned, or the one at "
                               "ADDRESS, as trench --live); records every episode")
    campaign.set_defaults(func=_cmd_campaign)

    exp = sub.add_parser("experiment", help="run the thesis' trenching experiments (Figs. 113-117): section "
                                            "figures, dig tables, summaries")
    exp.add_argument("names", nargs="*", metavar="NAME",
                     help="experiments of configs/experiments (fig113 ... fig117), YAML files, or 'all'; "
                          "none: list them")
    exp.add_argument("--list", action="store_true", help="list the experiments and exit")
    exp.add_argument("--out", metavar="DIR", default="runs/experiments", type=out_dir,
                     help="output directory, one subdirectory per experiment (default runs/experiments)")
    exp.add_argument("--dig-budget", type=dig_budget_type, metavar="N",
                     help=f"override every run's dig budget (1 to {MAX_DIG_BUDGET})")
    exp.add_argument("--seeds", type=int_in(1, 1000), default=1, metavar="N",
                     help="run every run with N seeds (its own, then the next N - 1) and pool them (default 1)")
    exp.add_argument("--verbose", action="store_true", help="print every scan and dig")
    exp.set_defaults(func=_cmd_experiment)

    learn = sub.add_parser("learn", help="learn to predict soil forces: data from digs, Tables 4-5, Fig. 81, "
                                         "nominal vs learned in the loop")
    learn.add_argument("--soil", metavar="NAME", help="soil preset of configs/soils.yaml (default: the scene's)")
    learn.add_argument("--digs", type=int_in(1, 100_000), default=30, metavar="N",
                       help="digs to collect (default 30)")
    learn.add_argument("--seed", type=seed_type, default=0, metavar="N", help="seeds the soil beds, actions and folds")
    learn.add_argument("--out", metavar="DIR", default="runs/learn", type=out_dir,
                       help="output directory (default runs/learn)")
    learn.add_argument("--dataset", metavar="FILE", type=out_file((".parquet", ".csv", ".npz")),
                       help="force data set (.parquet, .csv, .npz): loaded if it exists, else built and saved there")
    learn.add_argument("--folds", type=int_in(2, 1000), default=10, metavar="N",
                       help="cross-validation folds (default 10)")
    learn.add_argument("--split", choices=["samples", "digs", "both"], default="both",
                       help="cross-validate over shuffled samples (the thesis), whole digs, or both (default)")
    learn.add_argument("--compare", action="store_true",
                       help="also run episodes planned with the nominal wedge model and with learned predictors")
    learn.add_argument("--episodes", type=int_in(1, 1000), default=2, metavar="N",
                       help="episodes per predictor (default 2)")
    learn.add_argument("--dig-budget", type=dig_budget_type, default=6, metavar="N",
                       help="digs per episode (default 6)")
    learn.add_argument("--wrist-limit", type=float_in(10, 1e6), metavar="NM",
                       help="wrist pitch torque limit in the comparison [N m] (default: configs/robot.yaml)")
    learn.add_argument("--method", default="global", metavar="NAME",
                       help="learned predictor in the comparison: global, global_rls, nn3, lwr, lwr_scaled, net")
    learn.add_argument("--forgetting", type=float_in(0, 1, low_open=True), default=1.0, metavar="F",
                       help="forgetting factor of eq. 22 for a global regression in the comparison (default 1)")
    learn.set_defaults(func=_cmd_learn)

    figs = sub.add_parser("figures", help="redraw the thesis' figures (Figs. 20-91: soil forces in the world beside "
                          "the static wedge model, rotation centres, torques, feasible sets, planning time) as PNGs")
    figs.add_argument("names", nargs="*", metavar="NAME", help="figures to draw, e.g. fig54 fig59 (default: all; "
                      "see --list)")
    figs.add_argument("--list", action="store_true", help="list the figures and exit")
    figs.add_argument("--out", metavar="DIR", default="runs/figures", type=out_dir,
                      help="output directory, one NAME.png per figure (default runs/figures)")
    figs.add_argument("--seed", type=seed_type, default=0, metavar="N",
                      help="the worlds' seed (Fig. 59 also uses the next two; default 0)")
    figs.set_defaults(func=_cmd_figures)
