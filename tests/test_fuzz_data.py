"""Fuzzing every data-file reader: each case loads, or gives :class:`~excavsim.errors.DataFileError`
naming the file, never another exception, and never hangs.

The readers: force data sets (:meth:`ForceDataset.load`, CSV, NPZ and Parquet), saved elevation maps
(:meth:`ElevationMap.load`), demonstrations (:func:`load_demonstration`), Rerun recordings
(:func:`read_recording`, :func:`cut_paths`) and regression baselines (:func:`load_baseline`). Every
case starts from a valid file written by excavsim and garbles it: random bytes, truncation, flipped,
inserted or deleted bytes; the text formats also get structure mutations (lines and columns deleted,
values replaced by text, keys deleted or retyped), and the NPZ formats archives of the right names
holding arrays of other shapes and types.

``EXCAVSIM_FUZZ_EXAMPLES`` sets the cases per reader (default 50), as in test_fuzz_config.py.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from excavsim import constants
from excavsim.errors import DataFileError
from excavsim.execution.demonstration import Demonstration, load_demonstration
from excavsim.handoff.maps import ElevationMap
from excavsim.learning.dataset import COLUMNS, ForceDataset
from excavsim.studies.regress.suite import load_baseline
from excavsim.record.demo_reading import cut_paths
from excavsim.record.reading import read_recording

EXAMPLES = int(os.environ.get("EXCAVSIM_FUZZ_EXAMPLES", "50"))
HANG_S = 30  # a case still running after this long fails as a hang [s]
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])


class Hang(BaseException):
    """Raised by SIGALRM in a case still running after :data:`HANG_S` seconds."""


@contextlib.contextmanager
def _loads_or_refuses(path):
    """The reader inside loads, or refuses with a DataFileError that names ``path``; nothing else."""
    def on_alarm(signum, frame):
        raise Hang(f"{path}: still reading after {HANG_S} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(HANG_S)
    try:
        yield
    except DataFileError as exc:
        assert str(path) in str(exc), f"the message does not name the file: {exc}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


# ---------------------------------------------------------------- the valid files the cases start from
def _dataset() -> ForceDataset:
    rng = np.random.default_rng(0)
    return ForceDataset({c: rng.normal(size=6) for c in COLUMNS}, {"soil": "testbed_sand", "seed": "0"})


def _map() -> ElevationMap:
    return ElevationMap(0.55, -1.5, 0.05, np.full((4, 5), 0.5), np.ones((4, 5), bool), 1.25)


def _demonstration() -> Demonstration:
    t = np.arange(5) * 0.01
    pose = np.stack([2.0 + t, 0.5 - t, np.full(5, 0.3)], axis=-1)
    return Demonstration(t, pose, np.ones((5, 2)), 0.01, 0.0, "fuzz", "testbed_sand")


def _baseline() -> dict:
    return {"format": 2, "scenarios": {"tiny": {"seeds": [0, 1], "task": "trench", "end": ["done", "budget"], "sim_s": [10.0, 12.0],
                                                "metrics": {"removed_fraction": {"values": [0.5, 0.6]}}}}}


def _recording(path) -> None:
    """A small recording with what :func:`read_recording` and :func:`cut_paths` read: the tip F/T, the
    joint angles, a scanned map, the log and one executed cut."""
    import rerun as rr

    rec = rr.RecordingStream("excavsim", recording_id="fuzz", send_properties=False)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    rec.set_sinks(rr.FileSink(str(path)))
    t = np.arange(6) * 0.1
    for axis in "xyz":
        rec.send_columns(f"ft/tip/{axis}", indexes=[rr.TimeColumn("sim_time", duration=t)],
                         columns=rr.Scalars.columns(scalars=np.arange(6.0)))
    for name in constants.ACTUATORS:
        rec.send_columns(f"joint_deg/{name}", indexes=[rr.TimeColumn("sim_time", duration=t)],
                         columns=rr.Scalars.columns(scalars=np.linspace(0, 10, 6)))
    rec.set_time("sim_time", duration=0.05)
    xs, ys = np.meshgrid(np.arange(3) * 0.05, np.arange(2) * 0.05)
    rec.log("world/soil/scan", rr.Mesh3D(vertex_positions=np.stack([xs.ravel(), ys.ravel(), np.full(6, 0.5)], -1)))
    rec.log("log", rr.TextLog("plan 1: k 2.20 m, alpha 40 deg"))
    rec.set_time("sim_time", duration=0.55)
    rec.log("world/exec/path", rr.LineStrips3D([[[2.0, 0.0, 0.5], [2.2, 0.0, 0.4], [2.4, 0.0, 0.5]]]))
    rec.flush()
    rec.disconnect()


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> dict[str, bytes]:
    """The bytes of one valid file of every format, written by excavsim."""
    d = tmp_path_factory.mktemp("valid")
    out = {}
    for suffix in (".csv", ".npz", ".parquet"):
        _dataset().save(d / f"data{suffix}")
        out[f"data{suffix}"] = (d / f"data{suffix}").read_bytes()
    _map().save(d / "map.npz")
    _demonstration().save(d / "demo.json")
    (d / "baseline.json").write_text(json.dumps(_baseline()))
    _recording(d / "rec.rrd")
    out.update({name: (d / name).read_bytes() for name in ("map.npz", "demo.json", "baseline.json", "rec.rrd")})
    return out


def test_the_valid_files_load(valid, tmp_path):
    for name, data in valid.items():
        (tmp_path / name).write_bytes(data)
    for suffix in (".csv", ".npz", ".parquet"):
        loaded = ForceDataset.load(tmp_path / f"data{suffix}")
        assert np.allclose(loaded.forces, _dataset().forces) and loaded.meta == _dataset().meta
    assert np.array_equal(ElevationMap.load(tmp_path / "map.npz").heights, _map().heights)
    assert np.array_equal(load_demonstration(tmp_path / "demo.json").pose, _demonstration().pose)
    assert load_baseline(tmp_path / "baseline.json")["tiny"].seeds == [0, 1]
    rec = read_recording(tmp_path / "rec.rrd")
    assert rec["ft_tip"].shape == (6, 3) and rec["joint_deg"].shape == (6, len(constants.ACTUATORS))
    assert len(rec["maps"]) == 1 and rec["maps"][0][1].heights.shape == (2, 3)
    assert [p.shape for _, p in cut_paths(tmp_path / "rec.rrd")] == [(3, 3)]


# ---------------------------------------------------------------- byte mutations (every format)
@st.composite
def garbled(draw, data: bytes) -> bytes:
    """``data`` truncated, with bytes flipped, inserted or deleted, or replaced by random bytes."""
    action = draw(st.sampled_from(["random", "truncate", "flip", "insert", "delete", "empty"]))
    if action == "random":
        return draw(st.binary(max_size=2048))
    if action == "empty":
        return b""
    if action == "truncate":
        return data[:draw(st.integers(0, max(0, len(data) - 1)))]
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 8))):
        i = draw(st.integers(0, max(0, len(out) - 1)))
        if action == "flip" and out:
            out[i] ^= draw(st.integers(1, 255))
        elif action == "insert":
            out[i:i] = draw(st.binary(min_size=1, max_size=16))
        elif action == "delete" and out:
            del out[i:i + draw(st.integers(1, 16))]
    return bytes(out)


READERS = {
    "data.csv": ForceDataset.load, "data.npz": ForceDataset.load, "data.parquet": ForceDataset.load,
    "map.npz": ElevationMap.load, "demo.json": load_demonstration, "baseline.json": load_baseline,
    "rec.rrd": read_recording,
}


@pytest.mark.parametrize("name", list(READERS))
@FUZZ
@given(data=st.data())
def test_garbled_files_load_or_give_a_data_file_error(name, valid, tmp_path, data):
    path = tmp_path / name
    path.write_bytes(data.draw(garbled(valid[name]), label=name))
    with _loads_or_refuses(path):
        READERS[name](path)
    if name == "rec.rrd":
        with _loads_or_refuses(path):
            cut_paths(path)


# ---------------------------------------------------------------- structure mutations
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True),
                   st.text(max_size=8), st.lists(st.floats(-10, 10), max_size=4),
                   st.dictionaries(st.text(max_size=4), st.integers(), max_size=2))


@FUZZ
@given(data=st.data())
def test_csv_records_with_lines_or_columns_changed_give_a_data_file_error(valid, tmp_path, data):
    lines = valid["data.csv"].decode().splitlines()
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(lines) - 1))
        action = data.draw(st.sampled_from(["drop line", "drop column", "text value", "duplicate column",
                                            "rename column", "meta"]))
        cells = lines[i].split(",")
        j = data.draw(st.integers(0, len(cells) - 1))
        if action == "drop line":
            del lines[i]
        elif action == "drop column":
            lines = [",".join(c for k, c in enumerate(ln.split(",")) if k != j) for ln in lines]
        elif action == "text value":
            cells[j] = data.draw(st.text(max_size=6).filter(lambda s: "\n" not in s and "\r" not in s))
            lines[i] = ",".join(cells)
        elif action == "duplicate column" and len(lines) > 1:
            lines[1] = lines[1] + "," + data.draw(st.sampled_from(COLUMNS))
        elif action == "rename column" and len(lines) > 1:
            header = lines[1].split(",")
            header[j % len(header)] = data.draw(st.text(max_size=4).filter(lambda s: "," not in s and "\n" not in s))
            lines[1] = ",".join(header)
        elif action == "meta":
            lines[0] = "# excavsim " + json.dumps(data.draw(VALUES))
        if not lines:
            break
    path = tmp_path / "data.csv"
    path.write_text("\n".join(lines) + "\n")
    with _loads_or_refuses(path):
        ForceDataset.load(path)


ARRAYS = st.one_of(
    st.builds(np.zeros, st.lists(st.integers(0, 3), max_size=3).map(tuple)),
    st.builds(np.asarray, st.lists(st.floats(allow_nan=True), max_size=6)),
    st.builds(np.asarray, st.lists(st.text(max_size=3), min_size=1, max_size=3)),
    st.builds(np.asarray, st.sampled_from([True, 3, 2.5, "x", float("nan"), float("inf")])),
)


@pytest.mark.parametrize("name", ["data.npz", "map.npz"])
@FUZZ
@given(data=st.data())
def test_npz_archives_of_other_arrays_give_a_data_file_error(name, tmp_path, data):
    keys = (*COLUMNS, "meta") if name == "data.npz" else ("x0", "y0", "cell", "heights", "observed", "time")
    chosen = data.draw(st.lists(st.sampled_from(keys), unique=True, max_size=len(keys)))
    arrays = {k: data.draw(ARRAYS, label=k) for k in chosen}
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    path = tmp_path / name
    path.write_bytes(buffer.getvalue())
    with _loads_or_refuses(path):
        READERS[name](path)


def _mutate_json(data, doc):
    """``doc`` with one to four keys deleted, replaced, added or their values nested."""
    for _ in range(data.draw(st.integers(1, 4))):
        node = doc
        while isinstance(node, dict) and node and data.draw(st.booleans()):
            key = data.draw(st.sampled_from(sorted(node)))
            if not isinstance(node[key], dict):
                break
            node = node[key]
        if not isinstance(node, dict) or not node:
            continue
        key = data.draw(st.sampled_from(sorted(node)))
        action = data.draw(st.sampled_from(["delete", "replace", "add", "nest"]))
        if action == "delete":
            del node[key]
        elif action == "replace":
            node[key] = data.draw(VALUES)
        elif action == "add":
            node[data.draw(st.text(min_size=1, max_size=5))] = data.draw(VALUES)
        else:
            node[key] = [node[key], node[key]]
    return doc


@pytest.mark.parametrize("name", ["demo.json", "baseline.json"])
@FUZZ
@given(data=st.data())
def test_json_files_with_keys_changed_give_a_data_file_error(name, valid, tmp_path, data):
    doc = _mutate_json(data, json.loads(valid[name]))
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    with _loads_or_refuses(path):
        READERS[name](path)
