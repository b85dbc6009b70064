"""Fuzzing the loaders of user files: scenario, study, topology (2D and 3D), rail profile and record.

Random bytes, random text, TOML-shaped documents with svbi's own keys, and special files (a FIFO,
``/dev/zero``, a folder, a symbolic-link loop) must end in the loader's own error (``ScenarioError``,
``StudyError``, ``TopologyError``, ``RecordError``, the profile's ``ValueError``), never in another
exception, and never hang: every example has a deadline, and every call runs under an alarm.
"""

from __future__ import annotations

import contextlib
import os
import signal
import string
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from svbi.codegen.plain_types import TopologyError
from svbi.codegen.topology import load_topology
from svbi.codegen.topology3d import load_topology3d
from svbi.runtime.excitation.irregularity import read_profile
from svbi.runtime.excitation.records import RecordError, read_record
from svbi.runtime.scenario.schema import ScenarioError, load_scenario
from svbi.runtime.study.sweep import StudyError, load_study

SETTINGS = settings(
    max_examples=40,
    deadline=2000,  # ms per example: a hang fails the example, it does not stall the run
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    derandomize=True,  # the same examples on every run: a fast, reproducible test
)


@contextlib.contextmanager
def _alarm(seconds: int = 20) -> Iterator[None]:
    """A hang (a read that never ends) becomes a failure instead of a stalled test run."""

    def fail(signum: int, frame: object) -> None:
        raise TimeoutError(f"the loader hung for {seconds} s")

    previous = signal.signal(signal.SIGALRM, fail)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _profile(path: Path) -> object:
    return read_profile(path)


def _record(path: Path) -> object:
    return read_record(path, dt=0.01)


def _scenario(path: Path) -> object:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scenario(path)


LOADERS: dict[str, tuple[Callable[[Path], object], type[Exception], bool]] = {
    # name: (loader, its clean error, whether the message is a single line)
    "scenario": (_scenario, ScenarioError, False),  # one line per problem, below a heading
    "study": (load_study, StudyError, False),
    "topology": (load_topology, TopologyError, True),
    "topology3d": (load_topology3d, TopologyError, True),
    "profile": (_profile, ValueError, True),
    "record": (_record, RecordError, True),
}


def _load(name: str, path: Path) -> None:
    loader, error, one_line = LOADERS[name]
    try:
        with _alarm():
            loader(path)
    except error as exc:
        if one_line:
            assert "\n" not in str(exc), str(exc)
    # anything else (a traceback of the CLI) propagates and fails the example


KEYS = [
    "title", "bridge", "train", "solver", "track", "earthquake", "contact", "output", "spans",
    "span_length", "vehicle", "speed_kmh", "time_step", "duration", "irregularity", "vertical",
    "name", "kind", "parameters", "bodies", "suspensions", "wheels", "value", "dofs", "mass",
    "stiffness", "scenario", "axes", "zip", "cars", "method", "backend",
]  # fmt: skip
SCALARS = st.one_of(
    st.integers(min_value=-(10**6), max_value=10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.text(alphabet=string.ascii_letters + string.digits + " ._-*+/()e", max_size=12),
    st.sampled_from(["sprung-mass", "pioneer-2d", "none", "synthetic", "german-low", "z", "1.0e6"]),
)
TOML_LIKE = st.recursive(
    st.dictionaries(st.sampled_from(KEYS), SCALARS, max_size=4),
    lambda inner: st.dictionaries(
        st.sampled_from(KEYS), st.one_of(inner, st.lists(inner, max_size=2), SCALARS), max_size=5
    ),
    max_leaves=12,
)


def _toml(doc: dict) -> str:
    try:
        return tomli_w.dumps(doc)
    except (TypeError, ValueError):  # a float NaN in an array of tables and the like: plain text then
        return repr(doc)


@pytest.mark.parametrize("name", sorted(LOADERS))
@SETTINGS
@given(data=st.binary(max_size=400))
def test_random_bytes(tmp_path: Path, name: str, data: bytes) -> None:
    path = tmp_path / "input.toml"
    path.write_bytes(data)
    _load(name, path)


@pytest.mark.parametrize("name", sorted(LOADERS))
@SETTINGS
@given(text=st.text(max_size=300))
def test_random_text(tmp_path: Path, name: str, text: str) -> None:
    path = tmp_path / "input.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    _load(name, path)


@pytest.mark.parametrize("name", ["scenario", "study", "topology", "topology3d"])
@SETTINGS
@given(doc=TOML_LIKE)
def test_toml_shaped_documents(tmp_path: Path, name: str, doc: dict) -> None:
    path = tmp_path / "input.toml"
    path.write_text(_toml(doc), encoding="utf-8")
    _load(name, path)


@pytest.mark.parametrize("name", ["profile", "record"])
@SETTINGS
@given(
    rows=st.lists(
        st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=4)), max_size=3),
        max_size=30,
    )
)
def test_column_shaped_files(tmp_path: Path, name: str, rows: list[list]) -> None:
    path = tmp_path / "input.txt"
    path.write_text("\n".join(" ".join(str(v) for v in row) for row in rows), encoding="utf-8")
    _load(name, path)


@pytest.fixture
def special_files(tmp_path: Path) -> dict[str, Path]:
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    loop = tmp_path / "loop.toml"
    loop.symlink_to(loop.name)
    return {"fifo": fifo, "/dev/zero": Path("/dev/zero"), "folder": folder, "symlink loop": loop}


@pytest.mark.parametrize("name", sorted(LOADERS))
@pytest.mark.parametrize("kind", ["fifo", "/dev/zero", "folder", "symlink loop"])
def test_special_files(special_files: dict[str, Path], name: str, kind: str) -> None:
    _, error, _ = LOADERS[name]
    with pytest.raises(error):
        with _alarm():
            LOADERS[name][0](special_files[kind])
