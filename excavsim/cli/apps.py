"""The application commands: ``calibrate`` (fit a soil model to a force record) and ``playback``
(programming digs by demonstration: teleoperation, demonstrations from recordings, impedance playback)."""

from __future__ import annotations

import argparse
import pathlib

from excavsim.cli.live import live_viewer
from excavsim.config.arguments import float_in, int_in, out_dir, out_file, seed_type
from excavsim.errors import ConfigError, UsageError, shorten


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from excavsim.apps.calibrate import fit as cal
    from excavsim.apps.calibrate import run, table53

    if args.table_5_3 and (args.fix or args.brittleness or args.rate_effect):
        raise UsageError("--fix, --brittleness and --rate-effect belong to a record's fit; --table-5-3 identifies "
                         "all of Table 5.3's parameters from DiMaio's own forces")
    if args.brittleness and args.model != "wedge":
        raise UsageError("--brittleness is the wedge model's failure cycle; give it with --model wedge")
    if args.rate_effect and args.model != "wedge":
        raise UsageError("--rate-effect is the wedge model's rate effect on cohesion; give it with --model wedge")
    if args.table_5_3:
        print(f"excavsim calibrate --table-5-3: DiMaio's model identified from its own forces (Table 5.3, Fig. 5.40); "
              f"results in {args.out}")
        table53.table_5_3(args.out, noise_n=args.noise)
        return 0
    if args.record is None:
        raise UsageError("calibrate needs a RECORD (a force data set .npz, .parquet or .csv, or a Rerun "
                         "recording .rrd) or --table-5-3")
    record = pathlib.Path(args.record)
    fixed = cal.parse_fixes(args.model, args.fix)  # refused before any recording or fit
    if args.rrd and not args.record_digs:
        raise UsageError("--rrd FILE records the digs of --record-digs N; give --record-digs too")
    if args.rrd and pathlib.Path(args.rrd).suffix != ".rrd":
        raise ConfigError(f"--rrd {shorten(args.rrd)}: a Rerun recording's name ends in .rrd")
    if args.record_digs:
        if record.suffix == ".rrd":
            raise ConfigError(f"--record-digs saves a force data set (.npz, .parquet, .csv), not {record.name}; "
                              "record the episode with --rrd FILE as well")
        if record.suffix not in (".npz", ".parquet", ".csv"):
            raise ConfigError(f"--record-digs saves RECORD as a force data set: .npz, .parquet or .csv; given "
                              f"{shorten(record.name)}")
    run.calibrate_file(record, args.model, args.out, soil=args.soil, rerun_digs=not args.no_rerun, fixed=fixed,
                       brittleness=args.brittleness, rate_per_decade=args.rate_effect, record_digs_n=args.record_digs,
                       truth=args.truth, seed=args.seed, quiet=args.quiet, rrd=args.rrd)
    return 0


def _cmd_playback(args: argparse.Namespace) -> int:
    from excavsim.apps.playback import driver

    modes = [name for name, on in (("--teleop", args.teleop), ("--from-rrd", args.from_rrd), ("--demo", args.demo))
             if on]
    if len(modes) > 1:
        raise UsageError(f"playback: {' and '.join(modes)} cannot be combined; give one of --teleop, --from-rrd "
                         f"FILE.rrd, --demo FILE.json (or none for the chapter-6 experiment)")
    if args.keys is not None and not args.teleop:
        raise UsageError("playback: --keys is the key sequence of --teleop; give --teleop with it")
    if args.dig is not None and not args.from_rrd:
        raise UsageError("playback: --dig chooses the dig of --from-rrd FILE.rrd; give --from-rrd with it")
    if (args.live is not None or args.record) and not args.teleop:
        raise UsageError("playback: --live and --record show or record a --teleop session; give --teleop with them")
    if args.record and not args.record.endswith(".rrd"):
        raise ConfigError(f"--record must name an .rrd file; given {shorten(repr(args.record), 200)}")
    seeds = None
    if args.seeds is not None:
        if args.teleop or args.from_rrd or args.seed is not None:
            raise UsageError("playback: --seeds runs the chapter-6 experiment on several seeds; it cannot be "
                             "combined with --seed, --teleop or --from-rrd (give --seeds alone, or with --demo)")
        seeds = driver.seed_range(args.seeds)
    with live_viewer(args.live) as live:  # a viewer window that --live spawns ends with the command
        driver.command(args.out, machine=args.machine, seed=args.seed if args.seed is not None else 0, seeds=seeds,
                       sweep=not args.no_sweep, demo_path=args.demo, teleop=args.teleop, keys=args.keys,
                       record=args.record, live=live, from_rrd=args.from_rrd, dig=args.dig,
                       say=lambda line: print(line, flush=True))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the application commands to ``sub``."""
    calib = sub.add_parser("calibrate", help="fit a soil (wedge or DiMaio) to a force record; Table 5.3's "
                                             "identification experiment")
    calib.add_argument("record", nargs="?", metavar="RECORD",
                       help="force data set of digs (.npz, .parquet, .csv; `learn --dataset` or --record-digs "
                            "writes one) or a Rerun recording of an episode (.rrd: its F/T, joint angles, scans "
                            "and plans are read)")
    calib.add_argument("--model", choices=["wedge", "dimaio"], default="wedge",
                       help="the model whose soil parameters are fitted (default wedge)")
    calib.add_argument("--out", metavar="DIR", default="runs/calibrate", type=out_dir,
                       help="output directory (default runs/calibrate)")
    calib.add_argument("--fix", action="append", metavar="NAME=VALUE",
                       help="hold a parameter of --model's fit at VALUE and fit the rest (repeatable); wedge: "
                            "c_pa (or cohesion_pa), phi_deg, delta_deg, gamma_n_m3, e.g. cohesion_pa=0 for a "
                            "cohesionless sand; dimaio: b_t0, b_n0, mu, eps, rho, k, T_rt, T_rn, S")
    calib.add_argument("--soil", metavar="NAME", help="preset the fit starts from and the YAML completes "
                                                      "(default: the record's)")
    calib.add_argument("--record-digs", type=int_in(1, 1000), metavar="N",
                       help="first dig N random feasible digs in simulation and save their record as RECORD")
    calib.add_argument("--truth", choices=["wedge", "dimaio"], default="wedge",
                       help="the world's force model for --record-digs (default wedge)")
    calib.add_argument("--brittleness", type=float_in(0, 1, high_open=True), default=0.0, metavar="I_B",
                       help="the wedge's failure cycle: the share of the failure force lost at each failure, "
                            "which the record model averages over (default 0: eq. 8's crest, a quiet record; "
                            "0.2 for a record of the default world, scene.yaml truth.brittleness_index)")
    calib.add_argument("--rate-effect", type=float_in(0, 1), default=0.0, metavar="A",
                       help="the wedge's rate effect on cohesion: c rises by A per tenfold advance speed above "
                            "0.01 m/s, so that the fitted c is the strength at 0.01 m/s as a preset's (default 0: "
                            "the strength at the digs' rate; 0.1 for a clay of the default world, scene.yaml "
                            "truth.cohesion_rate_per_decade)")
    calib.add_argument("--quiet", action="store_true",
                       help="with --record-digs: the wedge's rate effect, failure-cycle drops, heterogeneity and "
                            "the F/T's digging disturbance off")
    calib.add_argument("--seed", type=seed_type, default=0, metavar="N", help="seed of --record-digs")
    calib.add_argument("--rrd", metavar="FILE", help="with --record-digs: also record the episode to this Rerun "
                                                     "recording (calibrate it with `excavsim calibrate FILE`)")
    calib.add_argument("--no-rerun", action="store_true",
                       help="skip re-running the recorded digs in simulation with the fitted soils")
    calib.add_argument("--table-5-3", action="store_true",
                       help="reproduce Table 5.3 and Fig. 5.40 (DiMaio's model identified from its own forces)")
    calib.add_argument("--noise", type=float_in(0, 1e4), default=5.0, metavar="N",
                       help="F/T noise of --table-5-3 per axis [N] (default 5, the scene's)")
    calib.set_defaults(func=_cmd_calibrate)

    pb = sub.add_parser("playback", help="programming digs by demonstration: replay a demonstrated dig in a stiffer "
                        "and a softer soil with fixed and variable impedance (DiMaio ch. 3, 6)")
    pb.add_argument("--seed", type=seed_type, default=None, metavar="N", help="the worlds' seed (default 0)")
    pb.add_argument("--seeds", metavar="SPEC", help="run the experiment on several seeds ('0-7', '0,2,5') and print "
                    "each soil's and controller's errors per seed and their mean; writes DIR/seeds.csv")
    pb.add_argument("--no-sweep", action="store_true", help="skip the velocity-weighting sweep (Figs. 6.46-6.48)")
    pb.add_argument("--teleop", action="store_true", help="make a demonstration by teleoperation from the terminal "
                    "(keys a/d w/s q/e move the tip, x finishes); writes DIR/teleop_demonstration.json")
    pb.add_argument("--keys", metavar="SEQUENCE", help="with --teleop: the keys as a string instead of the terminal")
    pb.add_argument("--live", nargs="?", const="", metavar="ADDRESS", help="with --teleop: stream the session to a "
                    "Rerun viewer (the F/T plot shows the force while driving); alone, spawn one (needs a display)")
    pb.add_argument("--record", metavar="FILE.rrd", type=out_file(()),
                    help="with --teleop: record the session to a Rerun file")
    pb.add_argument("--from-rrd", metavar="FILE.rrd", help="make a demonstration from a dig of a Rerun recording "
                    "(excavsim trench --record); writes DIR/rrd_demonstration.json")
    pb.add_argument("--dig", type=int_in(1, 100_000), metavar="N", help="with --from-rrd: which dig (default 1)")
    pb.add_argument("--demo", metavar="FILE.json", help="play back this demonstration file instead of recording one")
    from excavsim.apps.playback import DEFAULT_MACHINE, MACHINE_NAMES

    pb.add_argument("--machine", choices=MACHINE_NAMES, default=DEFAULT_MACHINE,
                    help=f"the machine, one of {', '.join(MACHINE_NAMES)} (default {DEFAULT_MACHINE}): with joint "
                    "servos and a wrist F/T it plays back with Table 6.5's impedance, with cylinders (an excavator) "
                    "with Table 4.1's, and with --teleop the keys z/c also swing its cab")
    pb.add_argument("--out", metavar="DIR", default="runs/playback", type=out_dir,
                    help="output directory (default runs/playback)")
    pb.set_defaults(func=_cmd_playback)
