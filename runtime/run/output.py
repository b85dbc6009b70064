"""Where `svbi run` writes, checked before anything is computed, and how a run stops on a signal.

* :func:`check_output` refuses, in one line, an output path that would lose data or fail only after
  the whole run: empty, not a ``.nc`` name, an existing folder or special file, under a regular file,
  in a folder that cannot take a new file, or one of the run's own inputs (:func:`run_inputs`:
  scenario, records, vehicle topology), compared by resolved path and by inode, so that a symbolic
  or hard link is caught too.
* :func:`incomplete_path`: incomplete results (a diverged or interrupted run) go to
  ``<stem>.incomplete.nc`` beside the requested file, never onto it: a file at ``-o`` is always a
  complete run.
* :func:`signals_interrupt`: while it is active, SIGINT, SIGTERM and SIGHUP (the terminal closed)
  raise :class:`RunInterrupted` in the main thread, so that ``finally`` clauses run (temporary files
  removed, compile folders deleted) and the time loop can hand back what it computed. Python's
  default for SIGTERM and SIGHUP is to die on the spot, with no clean-up at all.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...codegen.plain_types import builtin_topologies

if TYPE_CHECKING:
    import xarray as xr

    from ..scenario.schema import Scenario

SUFFIX = ".nc"
INCOMPLETE = ".incomplete"


class OutputPathError(ValueError):
    """The output path cannot take the results; the message is one line naming the path."""


class RunInterrupted(KeyboardInterrupt):
    """SIGINT, SIGTERM or SIGHUP arrived. ``results`` holds what the time loop had computed (or None when
    the signal came before or after the loop); ``exit_code`` is ``128 + signal number``."""

    def __init__(self, signum: int, results: xr.Dataset | None = None) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)
        self.results = results

    @property
    def signal_name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


def signal_name(exc: BaseException) -> str:
    """SIGINT for a plain KeyboardInterrupt (Python's own Ctrl-C), else the signal that raised it."""
    return exc.signal_name if isinstance(exc, RunInterrupted) else "SIGINT"


# --------------------------------------------------------------------------------------------------
# the output path


def incomplete_path(path: str | os.PathLike[str]) -> Path:
    """``run.nc`` -> ``run.incomplete.nc``: where incomplete results of a run go."""
    p = Path(path)
    return p.with_name(f"{p.stem}{INCOMPLETE}{SUFFIX}")


def run_inputs(scenario: Scenario) -> dict[str, Path]:
    """The files a run reads, by the key that names them (``scenario`` for the scenario file)."""

    inputs: dict[str, Path] = {}
    if scenario.source:
        inputs["scenario file"] = Path(scenario.source)
    vehicle = scenario.train.vehicle
    if vehicle not in builtin_topologies():
        inputs["train.vehicle"] = scenario.resolve_path(vehicle)
    if scenario.track.is_profile:
        inputs["track.irregularity"] = scenario.resolve_path(scenario.track.irregularity)
    eq = scenario.earthquake
    if eq is not None:
        for comp in ("vertical", "longitudinal"):
            names = eq.sources(comp)
            for k, name in enumerate(names):
                if name not in ("none", "synthetic"):
                    key = (
                        f"earthquake.{comp}[{k}]"
                        if isinstance(getattr(eq, comp), list)
                        else f"earthquake.{comp}"
                    )
                    inputs[key] = scenario.resolve_path(name)
    return inputs


def _same_file(a: Path, b: Path) -> bool:
    """Same file by resolved path, or by device and inode (hard links)."""
    try:
        if a.resolve() == b.resolve():
            return True
    except OSError:
        pass
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _folder_problem(folder: Path) -> str | None:
    """Why no new file can be created in ``folder`` (None if one can)."""
    existing = folder
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        return f"{existing} is a file, not a folder"
    if existing != folder:  # write_atomic creates the missing folders: the first existing one decides
        if not os.access(existing, os.W_OK | os.X_OK):
            return f"folder {existing} is not writable"
        return None
    try:  # the only sure test (read-only file systems, root, ACLs): create a file and remove it
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return f"folder {folder} is not writable ({exc.strerror or exc})"
    return None


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` are one file: by resolved path, or by device and inode (hard links)."""
    return _same_file(a, b)


def folder_problem(folder: Path) -> str | None:
    """Why no new file can be created in ``folder`` (None if one can): the check of
    :func:`check_output`, for other writers (``svbi sweep``)."""
    return _folder_problem(folder)


TEMPORARY_NAME_EXTRA = 40
"""Bytes that an atomic write adds to a file name for its temporary file (``.<name>.<host>-<pid>-
<random>.tmp``, ``run.atomic``), with room to spare."""


def _name_max(folder: Path) -> int:
    """The longest file name the file system of ``folder`` (or of its first existing parent) takes."""
    existing = folder
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    try:
        return int(os.pathconf(existing, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def _name_problem(path: Path, longest: str | None, option: str) -> str | None:
    """Why ``path`` cannot be created for its length (None if it can): a part of the path longer
    than the file system takes, or ``longest`` (the longest file name written beside it, whose
    temporary name is longer still) too long."""
    folder = path.parent if str(path.parent) else Path(".")
    name_max = _name_max(folder)
    for part in path.parts:
        if len(os.fsencode(part)) > name_max:
            size = len(os.fsencode(part))
            return f"{option} {path}: a name in the path is too long ({size} bytes; at most {name_max})"
    if longest is None:
        return None
    size = len(os.fsencode(longest)) + TEMPORARY_NAME_EXTRA
    if size > name_max:
        return (
            f"{option} {path}: the file name is too long: with its temporary and .incomplete.nc names "
            f"it needs {size} bytes, the file system takes at most {name_max}; give a shorter name"
        )
    return None


def prepare_folder(raw: str | os.PathLike[str], option: str, create: bool = True) -> Path:
    """Create the output folder ``raw`` (and its parents) for a command's files, or refuse it in one
    line (:class:`OutputPathError`): an existing file, a name too long, under a regular file, in a
    folder that cannot be written. With ``create=False``, only the checks (nothing is created)."""
    folder = Path(raw).expanduser()
    problem = _name_problem(folder, None, option)
    if problem is not None:
        raise OutputPathError(problem)
    try:
        if folder.exists() and not folder.is_dir():
            raise OutputPathError(f"{option} {folder}: exists and is not a folder")
        existing = folder
        while not existing.exists() and existing.parent != existing:
            existing = existing.parent
        if existing != folder and not existing.is_dir():
            raise OutputPathError(f"{option} {folder}: {existing} is a file, not a folder")
        if create:
            folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(
            f"{option} {folder}: cannot create the folder ({exc.strerror or exc})"
        ) from None
    problem = _folder_problem(folder)
    if problem is not None:
        raise OutputPathError(f"{option} {folder}: {problem}")
    return folder


def check_output(raw: str | os.PathLike[str], inputs: dict[str, Path] | Iterable[tuple[str, Path]]) -> Path:
    """The output path as given, if a run can write its results there; else :class:`OutputPathError`.

    Checks both the path and its ``.incomplete.nc`` sibling (where a stopped run writes).
    """
    try:
        return _check_output(raw, inputs)
    except OSError as exc:  # a path the system refuses outright (a loop of symbolic links...)
        raise OutputPathError(f"-o {os.fspath(raw)}: {exc.strerror or exc}") from None


def _check_output(raw: str | os.PathLike[str], inputs: dict[str, Path] | Iterable[tuple[str, Path]]) -> Path:
    text = os.fspath(raw)
    if not text.strip():
        raise OutputPathError("-o: the output path is empty; give a file name ending in .nc")
    path = Path(text).expanduser()
    if path.suffix.lower() != SUFFIX:
        raise OutputPathError(
            f"-o {text}: results are written as NetCDF; give a file name ending in .nc "
            f"(got {'no suffix' if not path.suffix else repr(path.suffix)})"
        )
    problem = _name_problem(path, incomplete_path(path).name, "-o")
    if problem is not None:
        raise OutputPathError(problem)
    items = list(inputs.items()) if isinstance(inputs, dict) else list(inputs)
    for target in (path, incomplete_path(path)):
        if target.is_dir():
            raise OutputPathError(f"-o {text}: {target} is a folder; give a file name ending in .nc")
        if target.exists() and not target.is_file():
            raise OutputPathError(f"-o {text}: {target} exists and is not a regular file")
        for key, source in items:
            if _same_file(target, source):
                what = "the scenario file" if key == "scenario file" else f"the file of {key}"
                raise OutputPathError(
                    f"-o {text}: {target} is {what} ({source}), an input of this run; "
                    "results would overwrite it"
                )
    problem = _folder_problem(path.parent if str(path.parent) else Path("."))
    if problem is not None:
        raise OutputPathError(f"-o {text}: {problem}")
    return path


# --------------------------------------------------------------------------------------------------
# signals


INTERRUPTING = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)
"""The signals that stop a run cleanly (exit status 128 + the signal's number: 130, 143, 129)."""


def _raise(signum: int, frame: Any) -> None:
    raise RunInterrupted(signum)


@contextlib.contextmanager
def signals_interrupt() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP raise :class:`RunInterrupted` inside the block (main thread only).

    A signal that the process inherited as ignored (``nohup``, a shell's background job) stays
    ignored; the previous handlers come back on exit.
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous: dict[int, Any] = {}
    for signum in INTERRUPTING:
        current = signal.getsignal(signum)
        if current is signal.SIG_IGN:
            continue
        previous[signum] = current
        signal.signal(signum, _raise)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
