"""The one playback driver, for any machine of :data:`excavsim.robot.machine.MACHINES` (DiMaio 1998 §6.1-6.3,
Figs. 6.42-6.48): demonstrate a dig in one soil, play it back in a stiffer and a softer one with each impedance
controller.

What differs between machines (the servos, the force reading, the world, the impedance, the demonstration and
the words of the report) is the machine's :class:`~excavsim.apps.playback.adapter.MachineAdapter`
(:func:`~excavsim.apps.playback.machines.adapter_for`); everything here is the same on every machine:

* the demonstration (:func:`record_demonstration`): the machine's own (the executor's cut of
  :data:`~excavsim.handoff.dig.DEMO_ACTION` on the T3, a scripted cut on an excavator), with a 10 cm free-motion
  descent onto its entry prepended (:meth:`~excavsim.execution.playback.Demonstration.with_approach`) so that
  the variable impedance shows its switch from the air to the soil; or a given one (``--demo``: teleoperated,
  :mod:`excavsim.apps.playback.teleop`, or read from a recording, :func:`demonstration_from_recording`);
* the controllers (:func:`controllers`) from the machine's impedance: the fixed high (position control), any
  moderate and the low impedance, and the variable one, eq. 3.37 with the
  :class:`~excavsim.execution.playback.DepthDual` depth law; where the machine's impedance has a
  velocity-weighting sweep (Figs. 6.46-6.48), with ``sweep`` also that sweep and two ablations (eq. 3.37 alone,
  the depth law on position control);
* each playback (:func:`play`) in a fresh world of the same seed: the machine goes to the demonstration's start
  and :class:`~excavsim.execution.playback.ImpedancePlayback` runs at the control rate;
* the experiment (:func:`run_playback`) over the chapter's soils (:func:`~excavsim.apps.playback.adapter.soils`):
  the errors per soil and controller (position RMS, force RMS, eq. 3.14's E, the soil in the bucket), printed
  and written to ``errors.csv``; on the T3 also the closing note (:func:`verdict`) and the figures
  (:mod:`excavsim.apps.playback.figures`); :func:`run_seeds` runs it over several seeds (``--seeds``) and prints
  each soil's and controller's errors per seed with their mean (:func:`seed_table`) and a closing note counting
  the seeds on which the variable controller wins (:func:`seed_verdict`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from excavsim.apps.playback import DEFAULT_MACHINE
from excavsim.apps.playback.adapter import APPROACH_M, APPROACH_S, CSV_FORMATS, DEMO_SOIL, W, Impedance, soils
from excavsim.apps.playback.machines import adapter_for
from excavsim.config import SoilParams
from excavsim.errors import ConfigError
from excavsim.execution.demonstration import Demonstration
from excavsim.execution.playback import DepthDual, FixedImpedance, ImpedancePlayback, PlaybackRun, VariableImpedance


def controllers(impedance: Impedance, sweep: bool = True) -> list:
    """The fixed impedances from position control down to the low one (Figs. 6.42-6.44) and the variable one
    (eq. 3.37 with the :class:`~excavsim.execution.playback.DepthDual` depth) of ``impedance``; with ``sweep``
    also its velocity-weighting sweep (Figs. 6.46-6.48) and two ablations: eq. 3.37 without the depth law, the
    depth law on position control (none where the impedance has no sweep)."""
    imp = impedance
    m, lo, hi, g, b = imp.mass_kg, imp.k_low_n_m, imp.k_high_n_m, imp.g_n_s_m, imp.damping_n_s_m
    laws = [FixedImpedance(name, m, k, damping=b) for name, k in imp.fixed]
    laws.append(VariableImpedance(imp.variable, m, lo, hi, g, depth=DepthDual(w=W), damping=b))
    if sweep and imp.g_sweep:
        laws += [VariableImpedance(imp.sweep_name(gs), m, lo, hi, gs, depth=DepthDual(w=W), damping=b)
                 for _, gs in imp.g_sweep]
        laws += [VariableImpedance(f"eq. 3.37 only (G={g:g})", m, lo, hi, g, damping=b),
                 FixedImpedance("position + depth", m, hi, depth=DepthDual(w=W), damping=b)]
    return laws


def record_demonstration(seed: int = 0, soil: str = DEMO_SOIL, *, machine: str = DEFAULT_MACHINE) -> Demonstration:
    """``machine``'s own demonstration in ``soil`` (the executor's dig on the T3, the scripted cut on an
    excavator), without the free descent."""
    return adapter_for(machine).record_demonstration(seed, soil)


def play(demo: Demonstration, soil: SoilParams, label: str, law, seed: int = 0, *,
         machine: str = DEFAULT_MACHINE) -> tuple[PlaybackRun, float]:
    """One playback of ``demo`` on ``machine`` in a fresh world of ``soil`` with impedance ``law``; the run and
    the soil in the bucket at its end [m^3] (privileged truth, for the table).

    Raises:
        GoalError: the demonstration's first pose is out of the machine's reach.
        ConfigError: the demonstration's period is not the machine's control period.
    """
    rig = adapter_for(machine).rig(soil, seed)
    rig.go_to_start(demo.pose[0], demo.waist)
    run = ImpedancePlayback(rig.servos, rig.arm, rig.force, law).run(demo, soil=label)
    return run, rig.bucket_m3()


def run_playback(out: Path | None = None, *, machine: str = DEFAULT_MACHINE, seed: int = 0, sweep: bool = True,
                 demo: Demonstration | None = None, progress: Callable[[str], None] = print) -> dict:
    """The experiment (see the module docstring) on ``machine``; returns ``{(soil, controller): errors}`` (with
    ``bucket_m3`` and ``outcome``) and writes the demonstration, the error table (and on the T3 the plots) into
    ``out``.

    Args:
        demo: a demonstration to play back instead of recording the machine's own (its first pose is
            reached by a joint move; no approach is prepended).

    Raises:
        ConfigError: ``demo`` is sampled at another period than the machine's control period.
    """
    pm = adapter_for(machine)
    imp = pm.impedance
    if demo is None:
        raw = pm.record_demonstration(seed)
        demo = raw.with_approach(APPROACH_M, APPROACH_S)
        progress(pm.demonstration_note(raw, demo))
    else:
        note = pm.given_note(demo)
        if note:
            progress(note)
        pm.check_rate(demo)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        demo.save(out / "demonstration.json")
    runs: dict[tuple[str, str], PlaybackRun] = {}
    table = {}
    progress(pm.table_header)
    chapter = soils()
    for label, soil in chapter.items():
        for law in controllers(imp, sweep and label != "same"):
            run, moved = play(demo, soil, label, law, seed, machine=machine)
            runs[label, law.name] = run
            e = table[label, law.name] = {**run.errors(W), "bucket_m3": moved, "outcome": run.outcome}
            progress(pm.table_row(label, law.name, e))
    changed = [k for k in chapter if k != "same"]
    if pm.chapter_report:
        progress(f"(demonstrated force peak {table['same', imp.position]['demo_force_peak_n']:.0f} N; W = {W:g})")
        for line in verdict(table, changed, imp):
            progress(line)
    if out is not None:
        _write_errors(out / "errors.csv", {None: table}, pm.csv_columns)
        if pm.chapter_report:
            from excavsim.apps.playback import figures

            figures.plot_runs(runs, out)
            figures.plot_errors(table, out / "errors.png")
            if sweep and imp.g_sweep:
                figures.plot_sweep(table, changed, imp, out / "sweep.png")
                figures.plot_duality(out / "duality.png")
            extra = ", sweep.png, duality.png" if sweep and imp.g_sweep else ""
            progress(f"wrote {out}/demonstration.json, errors.csv, errors.png{extra} and a figure per soil and "
                     "controller")
        else:
            progress(f"wrote {out}/demonstration.json and errors.csv")
    return table


def _write_errors(path: Path, tables: dict, columns: tuple[str, ...]) -> None:
    """The error tables as CSV: ``tables`` is ``{seed: table}`` (a ``seed`` column first) or ``{None: table}``."""
    seeded = list(tables) != [None]
    lines = [",".join((["seed"] if seeded else []) + ["soil", "controller", *columns])]
    for seed, table in tables.items():
        for (s, c), e in table.items():
            lines.append(",".join(([str(seed)] if seeded else []) + [s, c]
                                  + [format(e[k], CSV_FORMATS[k]) for k in columns]))
    path.write_text("\n".join(lines) + "\n")


MAX_SEEDS = 64  # a bound on --seeds (each seed is a whole experiment, about 8 s of CPU without the sweep)


def seed_range(text: str) -> list[int]:
    """The seeds of ``--seeds``: ``"0-7"``, ``"0,2,5"``, ``"3"`` or a mix (``"0-3,9"``), each in [0, 2**31).

    Raises:
        ExcavsimError: naming the bad part and the allowed forms.
    """
    allowed = "allowed: seeds N (0 <= N < 2**31) as 'A-B', 'A,B,C' or a mix such as '0-3,9'"
    seeds: list[int] = []
    for part in str(text).split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            a, b = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ConfigError(f"--seeds: {part.strip()[:40]!r} is not a seed or a range; {allowed}") from None
        if not 0 <= a <= b < 2 ** 31:
            raise ConfigError(f"--seeds: {part.strip()[:40]!r} is not an increasing range of seeds; {allowed}")
        if len(seeds) + b - a >= MAX_SEEDS:
            raise ConfigError(f"--seeds: more than {MAX_SEEDS} seeds given; {allowed}")
        seeds += [s for s in range(a, b + 1) if s not in seeds]
    return seeds


METRICS = (("pos_rms_m", 100.0, "position RMS [cm]", "{:7.2f}"), ("force_rms_n", 1.0, "force RMS error [N]", "{:7.0f}"),
           ("weighted_error", 1e-3, "E = mean W x~^2 + f~^2 [1e3]", "{:7.0f}"))


def seed_table(tables: dict[int, dict]) -> list[str]:
    """Per soil and metric (position RMS, force RMS error, E) a table of controllers against seeds, with the mean
    over the seeds; ``tables`` is ``{seed: run_playback's table}``."""
    seeds = list(tables)
    keys = list(dict.fromkeys(k for t in tables.values() for k in t))
    lines = []
    for soil in dict.fromkeys(s for s, _ in keys):
        names = [c for s, c in keys if s == soil]
        for key, scale, label, fmt in METRICS:
            lines.append(f"{soil}: {label}")
            lines.append(f"  {'controller':24s}" + "".join(f"{'seed ' + str(s):>9s}" for s in seeds) + f"{'mean':>9s}")
            for name in names:
                vals = [scale * tables[s][soil, name][key] for s in seeds]
                lines.append(f"  {name:24s}" + "".join("  " + fmt.format(v) for v in vals)
                             + "  " + fmt.format(float(np.mean(vals))))
    return lines


def seed_verdict(tables: dict[int, dict], soils: list[str], impedance: Impedance | None = None) -> list[str]:
    """The closing note over seeds: in each changed soil, on how many seeds the variable controller's E, position
    and force errors are below those of position control (high K) and of the low fixed impedance, with the means
    (the controllers' names are ``impedance``'s, the default machine's when None).

    What ch. 6 claims (§6.2-6.3, ch. 7) is the compromise: position control keeps the path and loses the force,
    the low impedance keeps the force and loses the path, and the variable impedance controls both "in favour of
    position control" (Fig. 6.48); both errors below *both* fixed extremes is the stricter reading of issue 24."""
    imp = impedance or adapter_for().impedance
    seeds, n = list(tables), len(tables)
    lines = []
    for soil in soils:
        v, p, f = ({s: tables[s][soil, c] for s in seeds} for c in (imp.variable, imp.position, imp.low))

        def below(key, other):
            return sum(v[s][key] < other[s][key] for s in seeds)

        def mean(d, key, scale=1.0):
            return scale * float(np.mean([d[s][key] for s in seeds]))

        e_wins = sum(v[s]["weighted_error"] < min(p[s]["weighted_error"], f[s]["weighted_error"]) for s in seeds)
        both = sum(v[s]["pos_rms_m"] < min(p[s]["pos_rms_m"], f[s]["pos_rms_m"])
                   and v[s]["force_rms_n"] < min(p[s]["force_rms_n"], f[s]["force_rms_n"]) for s in seeds)
        lines.append(
            f"{soil} over {n} seeds: {imp.variable} E lower than both fixed extremes on {e_wins}/{n} "
            f"(mean {mean(v, 'weighted_error', 1e-3):.0f} k vs position {mean(p, 'weighted_error', 1e-3):.0f} k, low K "
            f"{mean(f, 'weighted_error', 1e-3):.0f} k); position RMS below low K's on {below('pos_rms_m', f)}/{n}, "
            f"below position control's on {below('pos_rms_m', p)}/{n} (mean {mean(v, 'pos_rms_m', 100):.1f} cm vs "
            f"{mean(p, 'pos_rms_m', 100):.1f}, {mean(f, 'pos_rms_m', 100):.1f}); force RMS below position control's on "
            f"{below('force_rms_n', p)}/{n}, below low K's on {below('force_rms_n', f)}/{n} (mean "
            f"{mean(v, 'force_rms_n'):.0f} N vs {mean(p, 'force_rms_n'):.0f}, {mean(f, 'force_rms_n'):.0f}); "
            f"both errors below both extremes on {both}/{n}")
    return lines


def run_seeds(seeds: list[int], out: Path | None = None, *, machine: str = DEFAULT_MACHINE, sweep: bool = False,
              demo: Demonstration | None = None, progress: Callable[[str], None] = print) -> dict[int, dict]:
    """The experiment of :func:`run_playback` on each of ``seeds`` (each seed records its own demonstration
    unless ``demo`` is given, and replays it in worlds of that seed), then :func:`seed_table` and
    :func:`seed_verdict`; writes ``seeds.csv`` into ``out``. Returns ``{seed: table}``."""
    if not seeds:
        raise ConfigError("run_seeds: no seeds given")
    pm = adapter_for(machine)
    variable = pm.impedance.variable
    tables = {}
    for s in seeds:
        tables[s] = run_playback(None, machine=machine, seed=s, sweep=sweep, demo=demo, progress=lambda line: None)
        v = {soil: e for (soil, c), e in tables[s].items() if c == variable}
        progress(f"seed {s}: {variable} " + ", ".join(f"{soil} {100 * e['pos_rms_m']:.1f} cm / {e['force_rms_n']:.0f} N"
                                                      for soil, e in v.items()))
    for line in seed_table(tables):
        progress(line)
    changed = [soil for soil in dict.fromkeys(s for s, _ in tables[seeds[0]]) if soil != "same"]
    for line in seed_verdict(tables, changed, pm.impedance):
        progress(line)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        _write_errors(out / "seeds.csv", tables, pm.csv_columns)
        progress(f"wrote {out}/seeds.csv")
    return tables


def verdict(table: dict, soils: list[str], impedance: Impedance | None = None) -> list[str]:
    """The closing note: per changed soil, whether the variable controller's E, position and force
    errors are below each fixed extreme's (the controllers' names are ``impedance``'s, the default machine's
    when None)."""
    imp = impedance or adapter_for().impedance
    lines = []
    for soil in soils:
        v, p, f = (table[soil, c] for c in (imp.variable, imp.position, imp.low))
        wins = v["weighted_error"] < min(p["weighted_error"], f["weighted_error"])
        lines.append(
            f"{soil}: {imp.variable} E {v['weighted_error']:.0f} vs position {p['weighted_error']:.0f}, force "
            f"{f['weighted_error']:.0f} -> {'lower than both' if wins else 'NOT lower than both'}; "
            f"position RMS {100 * v['pos_rms_m']:.1f} cm (position control {100 * p['pos_rms_m']:.1f}, low K "
            f"{100 * f['pos_rms_m']:.1f}), force RMS error {v['force_rms_n']:.0f} N (position control "
            f"{p['force_rms_n']:.0f}, low K {f['force_rms_n']:.0f})")
    return lines


def demonstration_from_recording(path: str, dig: int, out: str | Path, *, machine: str = DEFAULT_MACHINE,
                                 say: Callable[[str], None] = print) -> Path:
    """``excavsim playback --from-rrd``: dig number ``dig`` (1-based) of a Rerun recording as a
    demonstration on ``machine``, written to ``out/rrd_demonstration.json``; returns that path.

    Raises:
        UsageError: the machine reads no wrist F/T (an excavator).
    """
    from excavsim.record.demo_reading import read_dig

    pm = adapter_for(machine)
    pm.check_from_recordings()
    recorded = read_dig(path, dig)
    demo = pm.demonstration_from_signals(recorded.joint_times, recorded.joints, recorded.ft_times, recorded.ft_tip,
                                         recorded.path_world, source=f"{path}, dig {recorded.dig}")
    return pm.save_demonstration(demo, out, "rrd_demonstration.json", say, what=f": dig {recorded.dig} of {path}")


def command(out: str | Path, *, machine: str = DEFAULT_MACHINE, seed: int = 0, seeds: list[int] | None = None,
            sweep: bool = True, demo_path: str | None = None, teleop: bool = False, keys=None,
            record: str | None = None, live: str | None = None, from_rrd: str | None = None, dig: int | None = None,
            say: Callable[[str], None] = print) -> Path | None:
    """``excavsim playback [--machine NAME]``: with ``teleop`` a teleoperated demonstration
    (:func:`~excavsim.apps.playback.teleop.teleop_session`), with ``from_rrd`` one read from a recording
    (:func:`demonstration_from_recording`), each written to ``out`` (the path returned); else the experiment
    (:func:`run_playback`), or over ``seeds`` (:func:`run_seeds`), with the demonstration of ``demo_path``
    instead of the machine's own when given."""
    from excavsim.execution.demonstration import load_demonstration

    if teleop:
        from excavsim.apps.playback.teleop import teleop_session

        return teleop_session(out, machine=machine, keys=keys, seed=seed, record=record, live=live, say=say)
    if from_rrd:
        return demonstration_from_recording(from_rrd, dig or 1, out, machine=machine, say=say)
    pm = adapter_for(machine)
    say(f"excavsim playback{pm.flag}: {pm.experiment}")
    demo = load_demonstration(demo_path) if demo_path else None
    out = Path(out)
    if seeds is not None:
        say(f"over seeds {', '.join(map(str, seeds))}: each seed records its own demonstration"
            + (" (here: the given one)" if demo is not None else "") + " and replays it in worlds of that seed")
        run_seeds(seeds, out, machine=machine, sweep=sweep, demo=demo, progress=say)
        return None
    run_playback(out, machine=machine, seed=seed, sweep=sweep, demo=demo, progress=say)
    return None
