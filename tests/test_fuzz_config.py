"""Fuzzing every configuration kind and the main commands: each case loads, or gives the package's own
error (exit status 2 from the command line), never another exception, and never hangs.

Cases mutate the shipped files' structure (replace, delete, add, retype, nest, scale numbers to and
beyond their limits) and their text (other encodings, stray bytes, truncation, repeated keys, aliases
and alias bombs, deep nesting, huge strings and integers). The command cases give fuzzed files and
values to ``trench``, ``plan``, ``campaign``, ``experiment``, ``learn`` and ``replay``; whatever would
start real work (an episode, a plan, a campaign) is replaced by a stub that raises :class:`WouldRun`,
so a case that gets that far counts as accepted and costs nothing.

The suite runs ``EXCAVSIM_FUZZ_EXAMPLES`` cases per configuration kind (default 50) and a third as
many per command. ``scripts/fuzz_config.py`` runs a large fuzz outside the suite and tallies
``EXCAVSIM_FUZZ_REPORT``, where every case appends one JSON line: its kind, its outcome
(``loaded``, ``clean_error``, ``traceback``, ``hang``) and, for a traceback, the exception.
"""

from __future__ import annotations

import contextlib
import copy
import json
import os
import signal
import traceback

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from excavsim import constants
from excavsim.cli import main
from excavsim.errors import ExcavsimError

EXAMPLES = int(os.environ.get("EXCAVSIM_FUZZ_EXAMPLES", "50"))
REPORT = os.environ.get("EXCAVSIM_FUZZ_REPORT")
HANG_S = 30  # a case still running after this long counts as a hang (SIGALRM) [s]
FUZZ = settings(max_examples=EXAMPLES, deadline=10_000, derandomize=REPORT is None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])


def _shipped(path) -> dict:
    return yaml.safe_load(path.read_text())


BASES = {
    "robot": _shipped(constants.ROBOT_YAML), "scene": _shipped(constants.SCENE_YAML),
    "soils": _shipped(constants.SOILS_YAML), "sensing": _shipped(constants.SENSING_YAML),
    "planner": _shipped(constants.PLANNER_YAML), "executor": _shipped(constants.EXECUTOR_YAML),
    "goal": _shipped(constants.TRENCHES_DIR / "small.yaml"),
    "spec": {"name": "fuzz", "goal": "small", "soil": "testbed_sand", "seed": 3, "dig_budget": 2,
             "robot": {"joints": {"wrist_pitch": {"torque_limit_nm": 500.0}}},
             "planner": {"grid": {"k_step_m": 0.2}}, "scene": {"initial_soil_height_m": 0.5}},
    "campaign": _shipped(constants.CONFIGS_DIR / "campaigns" / "tiny.yaml"),
    "experiment": _shipped(constants.CONFIGS_DIR / "experiments" / "fig114.yaml"),
    "regress": _shipped(constants.CONFIGS_DIR / "regress" / "small_sand.yaml"),
    "pile_loading_planar": _shipped(constants.CONFIGS_DIR / "pile_loading_planar.yaml"),
    "pile_loading": _shipped(constants.CONFIGS_DIR / "pile_loading.yaml"),
    "pile_loading_campaign": _shipped(constants.CONFIGS_DIR / "campaigns" / "pile_loading_machines.yaml"),
    "dump_trial": _shipped(constants.CONFIGS_DIR / "dump_trial.yaml"),
}


class WouldRun(Exception):
    """Raised by the stubs that replace real work: the command accepted its arguments and files."""


class Hang(BaseException):
    """Raised by SIGALRM in a case still running after :data:`HANG_S` seconds."""


@contextlib.contextmanager
def _watch(kind: str):
    """Run one case: record its outcome in the report, turn a hang into :class:`Hang`."""
    def on_alarm(signum, frame):
        raise Hang(f"{kind}: still running after {HANG_S} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(HANG_S)
    outcome, detail = "loaded", ""
    try:
        yield
    except ExcavsimError:
        outcome = "clean_error"
    except WouldRun:
        outcome = "loaded"
    except Hang as exc:
        outcome, detail = "hang", str(exc)
        raise
    except BaseException as exc:
        outcome, detail = "traceback", "".join(traceback.format_exception_only(exc)).strip()[:300]
        raise
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        if REPORT:
            with open(REPORT, "a") as f:
                f.write(json.dumps({"kind": kind, "outcome": outcome, "detail": detail}) + "\n")


# ---------------------------------------------------------------- structure mutations
LIMIT_NUMBERS = st.sampled_from([0, -1, 1, 0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e-9, 1e9, 1e300, -1e308, 1e308,
                                 2**31, 2**63, -2**63, 10**30, 0.005, 0.25, 4.0, 89.0, 90.0, 1000, 1001, 4000,
                                 4001, 100_000, 1e6, 1e8])
LEAVES = st.one_of(st.none(), st.booleans(), LIMIT_NUMBERS, st.integers(-10**6, 10**6),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
                   st.sampled_from(["sand", "small", "straight", "lean_clay", "../x.yaml", "/dev/zero", "", "\0"]),
                   st.lists(st.floats(-10, 10), max_size=4), st.dictionaries(st.text(max_size=4), st.integers(),
                                                                             max_size=2))


def _paths(node, prefix=()):
    """Every key path into nested dicts and lists of ``node``."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield (*prefix, key)
        yield from _paths(value, (*prefix, key))


@st.composite
def mutated(draw, base):
    """``base`` with one to four structure mutations."""
    data = copy.deepcopy(base)
    paths = list(_paths(data))
    for _ in range(draw(st.integers(1, 4))):
        path = draw(st.sampled_from(paths))
        parent = data
        try:
            for key in path[:-1]:
                parent = parent[key]
            leaf = path[-1]
            old = parent[leaf]
        except (KeyError, IndexError, TypeError):
            continue
        action = draw(st.sampled_from(["replace", "delete", "unknown", "scale", "nest", "limit"]))
        if action == "replace":
            parent[leaf] = draw(LEAVES)
        elif action == "delete":
            del parent[leaf]
        elif action == "unknown" and isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = draw(LEAVES)
        elif action == "scale" and isinstance(old, (int, float)) and not isinstance(old, bool):
            parent[leaf] = old * draw(st.sampled_from([-1, 0, 1e-12, 0.5, 1.0000001, 2, 10, 1e12, 1e300]))
        elif action == "nest":
            parent[leaf] = {"x": old} if draw(st.booleans()) else [old]
        elif action == "limit":
            parent[leaf] = draw(LIMIT_NUMBERS)
    return data


# ---------------------------------------------------------------- text mutations
def _bomb(levels: int) -> str:
    lines = ["b0: &b0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"b{i}: &b{i} [{', '.join([f'*b{i - 1}'] * 10)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


@st.composite
def documents(draw, base) -> bytes:
    """A file's bytes: a mutated document, possibly garbled at the text level."""
    data = draw(mutated(base)) if draw(st.booleans()) else copy.deepcopy(base)
    text = yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
    how = draw(st.sampled_from(["plain"] * 10 + ["utf16", "utf32", "latin1", "bytes", "truncate", "repeat_line",
                                                 "bomb", "anchors", "deep", "huge_string", "huge_int", "flow_deep",
                                                 "tabs", "empty"]))
    if how == "plain":
        return text.encode()
    if how == "utf16":
        return text.encode(draw(st.sampled_from(["utf-16", "utf-16-le", "utf-16-be"])))
    if how == "utf32":
        return text.encode("utf-32")
    if how == "latin1":
        return (text + "# \u00e9\u00e8\n").encode("latin-1", errors="replace")
    raw = text.encode()
    if how == "bytes":
        at = draw(st.integers(0, len(raw)))
        return raw[:at] + draw(st.binary(min_size=1, max_size=64)) + raw[at:]
    if how == "truncate":
        return raw[:draw(st.integers(0, len(raw)))]
    lines = text.splitlines(keepends=True)
    if how == "repeat_line" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        return "".join(lines[:i + 1] + [lines[i]] + lines[i + 1:]).encode()
    if how == "bomb":
        return (_bomb(draw(st.integers(3, 12))) + text).encode()
    if how == "anchors":
        return text.replace(": ", ": &a ", 1).replace("\n", "\nextra_alias: *a\n", 1).encode()
    if how == "deep":
        n = draw(st.sampled_from([10, 31, 32, 33, 100, 1000, 100_000]))
        return ("".join("  " * i + f"k{i}:\n" for i in range(min(n, 2000))) + "  " * min(n, 2000) + "v\n").encode()
    if how == "flow_deep":
        n = draw(st.sampled_from([30, 33, 1000, 200_000]))
        return (f"{next(iter(base))}: " + "[" * n + "]" * n + "\n").encode()
    if how == "huge_string":
        key = next(iter(base))
        return (text + f"{key}_x: {'s' * draw(st.sampled_from([100, 10_000, 2_000_000]))}\n").encode()
    if how == "huge_int":
        return (text + f"huge: {'9' * draw(st.sampled_from([20, 4300, 4301, 100_000]))}\n").encode()
    if how == "tabs":
        return text.replace("  ", "\t", 1).encode()
    return b""


@pytest.mark.parametrize("kind", sorted(BASES))
def test_every_config_kind_loads_or_gives_a_config_error(tmp_path, capsys, kind):
    @FUZZ
    @given(raw=documents(BASES[kind]))
    def case(raw):
        path = tmp_path / f"{kind}.yaml"
        path.write_bytes(raw)
        with _watch(kind):
            status = main(["validate", kind, str(path)])
            err = capsys.readouterr().err
            assert status in (0, 2), err
            assert "Traceback" not in err
            if status == 2:
                assert err.startswith("excavsim: error: ") and len(err) < 25_000, err[:3000]
                raise ExcavsimError(err)  # counted as a clean error

    case()


# ---------------------------------------------------------------- the commands
@pytest.fixture
def stubbed(monkeypatch):
    """Replace every piece of real work the commands could start by a stub raising WouldRun."""
    def would_run(*args, **kwargs):
        raise WouldRun

    import excavsim.studies.campaign.runner
    import excavsim.studies.experiment
    import excavsim.record
    import excavsim.studies.learning.compare
    import excavsim.rig.core  # before the patches: a module importing a name after them would keep the stub
    import excavsim.loop.scenario
    import excavsim.robot.reachability
    import excavsim.world.simulation

    monkeypatch.setattr(excavsim.loop.scenario, "run_spec", would_run)
    monkeypatch.setattr(excavsim.studies.campaign.runner, "run_campaign", would_run)
    monkeypatch.setattr(excavsim.studies.experiment, "run_experiment", would_run)
    monkeypatch.setattr(excavsim.studies.learning.compare, "run_learn", would_run)
    monkeypatch.setattr(excavsim.robot.reachability, "load_or_build", would_run)
    monkeypatch.setattr(excavsim.rig.core, "load_or_build", would_run)
    monkeypatch.setattr(excavsim.world.simulation, "Simulation", would_run)
    monkeypatch.setattr(excavsim.record, "TrenchRecorder", would_run)


ARG_VALUES = st.one_of(st.sampled_from(["-1", "0", "1", "2", "1000", "1001", "100000", str(2**32), str(2**64), "nan",
                                        "inf", "-inf", "1e-300", "1e308", "1.5", "", "x", "\0", "g" * 5000]),
                       st.text(max_size=20))


COMMANDS = ("trench", "plan", "campaign", "experiment", "learn", "replay", "demo", "cycle")


@st.composite
def commands(draw, tmp_path, cmd: str):
    """An argument list for the command ``cmd``, with fuzzed files, paths and numbers."""
    def fuzzed_file(kind: str, suffix: str = ".yaml") -> str:
        path = tmp_path / f"{kind}-{draw(st.integers(0, 3))}{suffix}"
        path.write_bytes(draw(documents(BASES[kind])))
        return str(path)

    a_file = tmp_path / "a_file"
    a_file.write_text("x\n")
    paths = st.sampled_from([str(a_file), f"{a_file}/sub", "/proc/x/y", str(tmp_path / "new" / "dir"), "",
                             "\0", "p" * 300, str(tmp_path)])
    numbers = ARG_VALUES
    argv = [cmd]
    if cmd == "replay":
        rrd = tmp_path / "r.rrd"
        rrd.write_bytes(draw(st.one_of(st.binary(max_size=256), st.binary(max_size=64).map(lambda b: b"RRF2" + b))))
        return [cmd, "--dry-run", draw(st.sampled_from([str(rrd), str(tmp_path), str(a_file), "\0", "m" * 5000]))]
    if cmd == "campaign":
        argv.append(fuzzed_file("campaign"))
    if cmd == "experiment":
        argv.append(draw(st.one_of(st.just(fuzzed_file("experiment")), st.sampled_from(["fig113", "nope", "all"]))))
    options = {
        "trench": {"--spec": lambda: fuzzed_file("spec"), "--goal": lambda: draw(st.one_of(
            st.just(fuzzed_file("goal")), st.sampled_from(["sand", "nope", "g" * 100_000, "../../etc/passwd"]))),
            "--seed": lambda: draw(numbers), "--dig-budget": lambda: draw(numbers),
            "--record": lambda: draw(paths) + draw(st.sampled_from(["", ".rrd"])),
            "--save-maps": lambda: draw(paths), "--robot-config": lambda: fuzzed_file("robot"),
            "--scene-config": lambda: fuzzed_file("scene"), "--soil": lambda: draw(ARG_VALUES)},
        "plan": {"--goal": lambda: fuzzed_file("goal"), "--planner-config": lambda: fuzzed_file("planner"),
                 "--robot-config": lambda: fuzzed_file("robot"), "--wrist-limit": lambda: draw(numbers),
                 "--out": lambda: draw(paths), "--soil": lambda: draw(ARG_VALUES)},
        "campaign": {"--out": lambda: draw(paths), "--workers": lambda: draw(numbers)},
        "experiment": {"--out": lambda: draw(paths), "--dig-budget": lambda: draw(numbers),
                       "--seeds": lambda: draw(numbers)},
        "learn": {"--out": lambda: draw(paths), "--digs": lambda: draw(numbers), "--seed": lambda: draw(numbers),
                  "--folds": lambda: draw(numbers), "--dataset": lambda: draw(paths) + ".npz",
                  "--wrist-limit": lambda: draw(numbers), "--forgetting": lambda: draw(numbers)},
        "demo": {"--seed": lambda: draw(numbers), "--robot-config": lambda: fuzzed_file("robot"),
                 "--scene-config": lambda: fuzzed_file("scene")},
        "cycle": {"--seed": lambda: draw(numbers), "--robot-config": lambda: fuzzed_file("robot")},
    }[cmd]
    for option in draw(st.lists(st.sampled_from(sorted(options)), min_size=1, max_size=4, unique=True)):
        argv += [option, options[option]()]
    return argv


@pytest.mark.parametrize("command", COMMANDS)
def test_the_commands_accept_or_refuse_fuzzed_arguments_with_status_2(tmp_path, capsys, stubbed, command):
    @settings(FUZZ, max_examples=max(10, EXAMPLES // 3))
    @given(data=st.data())
    def case(data):
        argv = data.draw(commands(tmp_path, command))
        with _watch(f"cli {argv[0]}"):
            status = main(argv)
            err = capsys.readouterr().err
            assert status in (0, 2), (argv[:4], err)
            assert "Traceback" not in err
            if status == 2:
                raise ExcavsimError(err)  # counted as a clean error

    case()
