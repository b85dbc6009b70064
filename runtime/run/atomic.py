"""Atomic file writes: never leave a half-written results file or figure behind.

* The file is written under a temporary name in the target folder and renamed onto the target in
  one step: a reader sees the previous file or the new one, never a part.
* SIGINT, SIGTERM and SIGHUP are deferred while the file is written: a handler that raises
  (Ctrl-C, ``svbi run``'s SIGTERM and SIGHUP) would otherwise raise anywhere inside the writing
  library, including inside one of its locks, whose clean-up then waits on that lock for ever. A
  signal that came during the write is acted on once the temporary file is complete, before the
  rename: its handler runs; one that raises (or ends the process) abandons the write, the
  temporary file is removed and the previous file kept.
* The temporary name ``.<name>.<host>-<pid>-<random>.tmp`` says which process writes it: a write
  killed outright (SIGKILL, a power cut) leaves it behind, and the next write of the same target
  removes those of processes that are gone, and any older than :data:`STALE_TEMPORARY_S`.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ..toolchain import host_tag, pid_alive

HELD_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)
STALE_TEMPORARY_S = 3600.0
"""A temporary file untouched for this long belongs to no write in progress (a write touches it as
it goes; the NetCDF image is built in memory first), whoever made it: the next write removes it."""
TEMPORARY_SUFFIX = ".tmp"


@contextlib.contextmanager
def _signals_deferred() -> Iterator[list[int]]:
    """Inside the block, SIGINT, SIGTERM and SIGHUP only record their arrival in the yielded list;
    their handlers come back on exit. Python runs signal handlers in the main thread, whichever
    thread the signal reaches (blocking it in this thread would not do: a library's thread, e.g.
    BLAS, takes it), so this replaces the handlers there; in another thread a handler cannot
    interrupt the write and nothing is done. A signal ignored, or handled outside Python, is left
    alone."""
    arrived: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield arrived
        return
    previous: dict[int, Any] = {}

    def record(signum: int, frame: Any) -> None:
        arrived.append(signum)

    try:
        for signum in HELD_SIGNALS:
            current = signal.getsignal(signum)
            if current is signal.SIG_IGN or current is None:
                continue
            previous[signum] = current
            signal.signal(signum, record)
        yield arrived
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _act_on(arrived: list[int], tmp: str) -> None:
    """Deliver the signals that came during the write again, now that their handlers are back: a
    handler that raises abandons the write (the caller removes ``tmp``); where a signal's action is
    to end the process (SIG_DFL), ``tmp`` is removed first."""
    signals = list(dict.fromkeys(arrived))
    if any(signal.getsignal(s) is signal.SIG_DFL for s in signals):
        Path(tmp).unlink(missing_ok=True)
    for signum in signals:
        signal.raise_signal(signum)
    if not os.path.lexists(tmp):  # handlers that did not end the process, after a removal
        raise InterruptedError(f"interrupted by {signal.Signals(signals[0]).name} while writing")


def _prefix(path: Path) -> str:
    return f".{path.name}."


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files of earlier writes of ``path`` that no write in progress owns:
    made on this machine by a process that is gone, or untouched for :data:`STALE_TEMPORARY_S`.
    Returns what was removed."""
    path = Path(path)
    prefix, host, now = _prefix(path), host_tag(), time.time()
    removed = []
    try:
        names = [n for n in os.listdir(path.parent) if n.startswith(prefix) and n.endswith(TEMPORARY_SUFFIX)]
    except OSError:
        return removed
    for name in names:
        middle = name[len(prefix) : -len(TEMPORARY_SUFFIX)]
        parts = middle.split("-")
        dead = len(parts) == 3 and parts[0] == host and parts[1].isdigit() and not pid_alive(int(parts[1]))
        candidate = path.parent / name
        try:
            st = candidate.lstat()
        except OSError:
            continue
        if not (dead or now - st.st_mtime > STALE_TEMPORARY_S):
            continue
        with contextlib.suppress(OSError):
            candidate.unlink()
            removed.append(candidate)
    return removed


def write_atomic(path: str | os.PathLike[str], write: Callable[[Path], None]) -> Path:
    """Call ``write(temporary path)`` in the target folder, then rename onto ``path`` in one step.

    The temporary file lives in the same folder so that ``os.replace`` is atomic; it gets the usual
    permissions (``mkstemp`` would leave it private). On any error, and on a signal that raises
    (``KeyboardInterrupt``, ``run_output.RunInterrupted``), it is removed and ``path`` is untouched.
    SIGINT, SIGTERM and SIGHUP are deferred during ``write`` and acted on before the rename (see
    the module doc). Temporary files of earlier writes of ``path`` whose process is gone are removed
    first.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    tmp: str | None = None
    try:
        with _signals_deferred() as arrived:
            fd, tmp = tempfile.mkstemp(
                dir=path.parent, prefix=f"{_prefix(path)}{host_tag()}-{os.getpid()}-", suffix=TEMPORARY_SUFFIX
            )
            os.close(fd)
            write(Path(tmp))
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        if arrived:  # a signal came during the write: its handler acts now, before the rename
            _act_on(arrived, tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            if os.path.lexists(tmp):
                Path(tmp).unlink(missing_ok=True)
            elif isinstance(exc, KeyboardInterrupt):  # a signal just after the rename: written
                exc.written = path  # type: ignore[attr-defined]
        raise
    return path
