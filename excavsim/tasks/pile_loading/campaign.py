"""Loading from a pile in MuJoCo over machines and seeds (Singh 1995 §7.2.1): ``excavsim load --mujoco``, ``--campaign``.

The episodes are the task's (:class:`~excavsim.tasks.pile_loading.task.LoadTask`, cycled by
:func:`~excavsim.tasks.pile_loading.task.run_loading_episode`); this module runs several and judges them together:
:func:`run_episodes` an episode of each machine, said run by run and compared with the thesis' 2-D
results (:func:`format_mujoco_comparison`); :func:`write_campaign` a campaign file's machines over its seeds
(:func:`run_loading_campaign`), per machine beside the 2-D simulation on the same pile (:func:`same_pile_2d`)
and the thesis (:func:`format_campaign`, Figs. 108-109).
"""

from __future__ import annotations

import pathlib

import numpy as np

from excavsim.errors import UsageError
from excavsim.tasks.pile_loading import planar as ld
from excavsim.tasks.pile_loading.config import LoadingCampaign, LoadingMujocoConfig, load_loading_campaign
from excavsim.tasks.pile_loading.task import MujocoRun, format_run, load_mujoco_config, run_loading_episode
from excavsim.tasks.pile_loading.world.scene import MACHINES


# ---------------------------------------------------------------------------------------------- episodes
def format_mujoco_comparison(rows: list[tuple[str, MujocoRun]], units_m2: float = 0.01) -> str:
    """The episodes beside the thesis' 2-D results (§7.2.1), delivered per dig in units of soil of the section
    (the lane's volume over its width; 1 unit = ``units_m2`` m^2), spilled in m^3."""
    lines = [f"{'machine':<8} {'digs':>5} {'per dig (units)':>16} {'efficiency':>11} {'removed':>8} {'spilled':>8} "
             f"{'thesis per dig':>15} {'thesis eff.':>12}"]
    for name, run in rows:
        per = run.per_dig() / run.width_m / units_m2
        th = ld.THESIS[name]
        lines.append(f"{name:<8} {len(run.digs):5d} {per:16.1f} {100 * run.efficiency():10.0f}% "
                     f"{100 * run.removed_fraction:7.1f}% {run.spilled_m3:8.3f} {th['per_dig']:15.1f} "
                     f"{100 * th['efficiency']:11.0f}%")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------- campaigns
def same_pile_2d(name: str, cfg: LoadingMujocoConfig, cfg2d: ld.LoadingConfig) -> ld.Run:
    """The 2-D simulation of §7.2.1 (:func:`excavsim.tasks.pile_loading.planar.simulate_pile`: exact terrain, the
    swept area removed, settlement) on the episode's pile: the lane's length, 5 cm columns, faces at the world
    soil's repose."""
    from excavsim.config import get_soil
    from excavsim.tasks.pile_loading.world.pile2d import trapezoid_pile

    repose = get_soil(cfg.soil).repose_angle_deg
    pile = trapezoid_pile(cfg.pile.height, cfg.pile.top, cfg.pile.foot, 8.5, 0.05, repose)
    spec = getattr(cfg2d.machines, name)
    return ld.simulate_pile(ld.make_machine(cfg2d, name), ld.make_rules(cfg2d, spec.capacity_units), pile, name=name,
                       max_digs=cfg.max_digs)


def run_loading_campaign(spec: LoadingCampaign, *, cfg: LoadingMujocoConfig | None = None,
                         cfg2d: ld.LoadingConfig | None = None, progress=None) -> list[tuple[str, int, MujocoRun]]:
    """Every (machine, seed) episode of ``spec``, in sequence."""
    cfg = cfg or load_mujoco_config(spec.mujoco_config)
    cfg2d = cfg2d or ld.load_loading_config()
    rows = []
    for name in spec.machines:
        for seed in spec.seeds:
            run = run_loading_episode(name, seed=seed, cfg=cfg, cfg2d=cfg2d)
            rows.append((name, seed, run))
            if progress:
                progress(f"  {name} seed {seed}: " + _campaign_line(run))
    return rows


def _campaign_line(run: MujocoRun, units_m2: float = 0.01) -> str:
    per = run.per_dig() / run.width_m / units_m2
    return (f"{len(run.digs)} digs, {100 * run.removed_fraction:.1f} % removed, {per:.1f} units delivered per dig "
            f"({100 * run.efficiency():.0f} %), {run.spilled_m3:.3f} m^3 spilled, "
            f"{'done' if run.done else 'NOT done'} ({run.reason})")


def format_campaign(rows: list[tuple[str, int, MujocoRun]], two_d: dict[str, ld.Run], units_m2: float = 0.01) -> str:
    """The campaign's episodes, then per machine their mean and spread beside the 2-D simulation on the same
    pile and the thesis (§7.2.1, Figs. 108-109; its own pile). Units: 1 unit = ``units_m2`` m^2 of the section."""
    lines = [f"{'machine':<7} {'seed':>4} {'digs':>4} {'removed':>8} {'units/dig':>9} {'eff.':>5} {'spilled m3':>10} "
             f"{'map left m3':>11} {'done':>4}  end"]
    for name, seed, run in rows:
        per = run.per_dig() / run.width_m / units_m2
        lines.append(f"{name:<7} {seed:4d} {len(run.digs):4d} {100 * run.removed_fraction:7.1f}% {per:9.1f} "
                     f"{100 * run.efficiency():4.0f}% {run.spilled_m3:10.3f} {run.map_end_m3:11.3f} "
                     f"{'yes' if run.done else 'NO':>4}  {run.reason}")
    lines += ["", f"{'machine':<7} {'episodes':>8} {'done':>5} {'digs':>11} {'units/dig':>12} {'efficiency':>11} "
              f"{'spilled m3':>11} | {'2-D same pile':>22} | thesis"]
    for name in dict.fromkeys(n for n, _, _ in rows):
        runs = [r for n, _, r in rows if n == name]
        digs = np.array([len(r.digs) for r in runs], float)
        per = np.array([r.per_dig() / r.width_m / units_m2 for r in runs])
        eff = np.array([100 * r.efficiency() for r in runs])
        spill = np.array([r.spilled_m3 for r in runs])
        t2 = two_d.get(name)
        two = (f"{len(t2.digs)} digs, {t2.per_dig() / units_m2:.1f}, {100 * t2.efficiency():.0f} %" if t2 is not None
               else "-")
        th = ld.THESIS[name]
        thesis = ((f"{th['digs']} digs, " if "digs" in th else "")
                  + f"{th['per_dig']:.1f}, ≈ {100 * th['efficiency']:.0f} %")
        lines.append(f"{name:<7} {len(runs):8d} {sum(r.done for r in runs):5d} {digs.mean():5.1f} ± {digs.std():3.1f} "
                     f"{per.mean():6.1f} ± {per.std():3.1f} {eff.mean():5.0f} ± {eff.std():2.0f}% "
                     f"{spill.mean():5.3f} ± {spill.std():.3f} | {two:>22} | {thesis}")
    return "\n".join(lines)


def write_campaign(campaign: str | pathlib.Path, out: str | pathlib.Path, *, cfg2d: ld.LoadingConfig,
                   mujoco_config: str | pathlib.Path | None = None, say=print) -> bool:
    """``excavsim load --campaign``: the campaign file's machines over its seeds in MuJoCo, judged
    together beside the 2-D simulation of the same pile; the table goes to ``out/campaign.txt``.

    Args:
        campaign: the campaign file (e.g. ``configs/campaigns/pile_loading_machines.yaml``).
        cfg2d: the 2-D loading configuration (the machines' numbers).
        mujoco_config: overrides the campaign's MuJoCo loading configuration.

    Returns:
        Whether every episode finished its work.
    """
    spec = load_loading_campaign(campaign)
    mcfg = load_mujoco_config(mujoco_config or spec.mujoco_config)
    say(f"excavsim load --campaign: {', '.join(spec.machines)} x seeds {spec.seeds} in MuJoCo, pile "
        f"{mcfg.pile.height:g} m high, soil {mcfg.soil}")
    rows = run_loading_campaign(spec, cfg=mcfg, cfg2d=cfg2d, progress=say)
    two_d = {name: same_pile_2d(name, mcfg, cfg2d) for name in spec.machines}
    table = format_campaign(rows, two_d, cfg2d.units_m2)
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "campaign.txt").write_text(table + "\n")
    say(table)
    say(f"wrote {out / 'campaign.txt'}")
    return all(r.done for _, _, r in rows)


def run_episodes(*, cfg2d: ld.LoadingConfig, machine: str | None = None, seed: int = 0,
                 mujoco_config: str | pathlib.Path | None = None, record: str | None = None, say=print) -> bool:
    """``excavsim load --mujoco``: a loading episode of each machine (or of ``machine``) in MuJoCo,
    said run by run and compared.

    Args:
        cfg2d: the 2-D loading configuration (the machines' numbers).
        machine: one of :data:`MACHINES` (default both).
        seed: the episodes' seed.
        mujoco_config: the MuJoCo loading configuration (default ``configs/pile_loading.yaml``).
        record: a Rerun file to record the episode to (one machine only).

    Returns:
        Whether every episode finished its work.
    """
    mcfg = load_mujoco_config(mujoco_config)
    names = [machine] if machine else list(MACHINES)
    if record and len(names) > 1:
        raise UsageError("--record writes one episode: give --machine loader or --machine shovel with it")
    rows = []
    for name in names:
        say(f"excavsim load --mujoco: front {name}, pile {mcfg.pile.height:g} m high, soil {mcfg.soil}, seed {seed}")
        observer = None
        if record:
            from excavsim.tasks.pile_loading.recording import LoadingRecorder

            observer = LoadingRecorder(record)
        run = run_loading_episode(name, seed=seed, cfg=mcfg, cfg2d=cfg2d, observer=observer, progress=say)
        say(format_run(run))
        rows.append((name, run))
        if record:
            say(f"recorded to {record}")
    if len(rows) > 1:
        say("\n" + format_mujoco_comparison(rows))
    return all(r.done for _, r in rows)

