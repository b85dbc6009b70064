"""Compiled kernels: build generated C into a per-user cache and call it from Python.

``load_kernels(model)`` returns a :class:`ModelKernels` whose kernels are called with NumPy arrays,
one per kernel input (in the ABI order of ``svbi.codegen.kernels``), and return dense 2-D arrays,
one per output, whatever the backend:

    >>> k = load_kernels("pioneer-2d")                   # C backend, compiled once and cached
    >>> M = k.mass_matrix(k.defaults)                    # (14, 14) ndarray
    >>> kc = load_kernels("pioneer-2d", backend="casadi")  # same call, CasADi virtual machine

The C backend compiles the model's sources with the system compiler (``$CC``, default ``cc``;
flags ``-O3 -fPIC -shared``) into ``$SVBI_CACHE_DIR``, ``$XDG_CACHE_HOME/svbi`` or
``~/.cache/svbi`` (``<sha256>/`` in it), where the
hash covers the sources, the compiler command, its version text and the flags. An entry is built in
a temporary folder and renamed into place, so a crash or a concurrent build never leaves a
half-written entry; a build folder left by a killed compile is removed by the next build
(:func:`remove_stale_builds`). A marker file records the sha256 of the library; an entry whose marker or
library does not match, or that ``dlopen`` rejects, is rebuilt. With no working compiler the loader
falls back to the CasADi backend and warns once; with an unwritable cache folder it builds in a
private temporary folder (``<temp>/svbi-cache-<uid>``, used only if it belongs to the user and is
closed to others, else a fresh one) and says so.

Kernel objects hold their own argument and work buffers: they are not thread-safe.
"""

from __future__ import annotations

import atexit
import ctypes
import functools
import hashlib
import json
import os
import shlex
import shutil
import stat
import subprocess
import tempfile
import time
import uuid
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..codegen.plain_types import PYTHON_KERNELS_FILE

DEFAULT_FLAGS: tuple[str, ...] = ("-O3", "-fPIC", "-shared")
MARKER = "svbi-build.json"
MANIFEST = "manifest.json"
COMPILE_TIMEOUT_S = 600
STALE_BUILD_S = 2 * COMPILE_TIMEOUT_S
"""A build folder older than this belongs to no build in progress (a compile is killed after
COMPILE_TIMEOUT_S), whoever made it: the next build removes it."""
BUILD_PREFIX = ".build-"


class CompilerError(RuntimeError):
    """The C compiler is missing or failed; the message holds the command and its output."""


class BackendFallbackWarning(RuntimeWarning):
    """The C backend is unavailable and the CasADi backend is used instead."""


class CacheWarning(RuntimeWarning):
    """The compiled-kernel cache folder is unusable; a temporary folder is used instead."""


_warned: set[str] = set()


def _warn_once(key: str, message: str, category: type[Warning]) -> None:
    if key not in _warned:
        _warned.add(key)
        warnings.warn(message, category, stacklevel=3)


# ---------------------------------------------------------------------------------------------
# Cache and compiler
# ---------------------------------------------------------------------------------------------


def _writable(folder: Path) -> OSError | None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return exc
    return None


def default_cache_root() -> Path:
    """``$SVBI_CACHE_DIR``, else ``$XDG_CACHE_HOME/svbi`` (an absolute ``XDG_CACHE_HOME`` only, as
    the XDG specification says), else ``~/.cache/svbi``."""
    if os.environ.get("SVBI_CACHE_DIR"):
        return Path(os.environ["SVBI_CACHE_DIR"])
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "svbi"
    return Path.home() / ".cache" / "svbi"


def cache_root(cache_dir: str | os.PathLike[str] | None = None) -> Path:
    """The cache folder: ``cache_dir``, else :func:`default_cache_root`; if that cannot be written,
    a private folder in the temporary folder (:func:`_fallback_root`)."""
    root = Path(cache_dir) if cache_dir is not None else default_cache_root()
    problem = _writable(root)
    if problem is None:
        return root
    fallback = _fallback_root()
    _warn_once(
        f"cache:{root}",
        f"svbi: the kernel cache folder {root} is not writable ({problem}); using {fallback} instead. "
        "Set SVBI_CACHE_DIR to a writable folder to keep compiled kernels between sessions.",
        CacheWarning,
    )
    return fallback


_fallbacks: dict[str, Path] = {}


def private_folder_problem(folder: Path) -> str | None:
    """Why ``folder`` is not safe to load compiled code from (None if it is): it must be a folder,
    not a symbolic link, belong to this user and be closed to everybody else (mode 0700 or
    stricter), so that no other user can plant a library in it."""
    try:
        st = os.lstat(folder)
    except OSError as exc:
        return f"cannot be used ({exc.strerror or exc})"
    if stat.S_ISLNK(st.st_mode):
        return "is a symbolic link"
    if not stat.S_ISDIR(st.st_mode):
        return "is not a folder"
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"belongs to another user (uid {st.st_uid})"
    if stat.S_IMODE(st.st_mode) & 0o077:
        return f"is open to other users (mode {stat.S_IMODE(st.st_mode):o}, not 700)"
    return None


def _fallback_root() -> Path:
    """``<temp>/svbi-cache-<uid>``, created private (mode 0700), if it is this user's and private
    (:func:`private_folder_problem`); otherwise a fresh private folder for this process (removed at
    exit), with a warning that says why. Looked up once per process."""
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    temp = tempfile.gettempdir()
    if temp in _fallbacks:
        return _fallbacks[temp]
    shared = Path(temp) / f"svbi-cache-{uid}"
    try:
        shared.mkdir(mode=0o700)
    except FileExistsError:
        pass
    except OSError:
        pass  # reported by the checks below
    problem = private_folder_problem(shared)
    if problem is None and (error := _writable(shared)) is not None:
        problem = f"is not writable ({error.strerror or error})"
    if problem is None:
        _fallbacks[temp] = shared
        return shared
    fresh = Path(tempfile.mkdtemp(prefix=f"svbi-cache-{uid}-"))  # private by construction
    atexit.register(shutil.rmtree, fresh, ignore_errors=True)
    _warn_once(
        f"fallback:{shared}",
        f"svbi: {shared} {problem}: compiled code is never loaded from it; using {fresh} for this "
        "process only (compiled again by every run). Remove that folder, or set SVBI_CACHE_DIR to a "
        "folder of your own.",
        CacheWarning,
    )
    _fallbacks[temp] = fresh
    return fresh


def compiler_command() -> list[str]:
    """The C compiler command: ``$CC`` (may hold flags) or ``cc``."""
    return shlex.split(os.environ.get("CC") or "cc")


@functools.lru_cache(maxsize=8)
def _compiler_identity(cc: tuple[str, ...]) -> str:
    # The version text goes into the cache key, so upgrading the compiler rebuilds. A compiler
    # that cannot even report its version is caught when it fails to compile. Asked once per
    # process: a run loads two libraries (the loop and the force filter).
    try:
        done = subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout if done.returncode == 0 else ""


def _sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _library_name(name: str) -> str:
    return f"lib{name}.so"


def _valid_entry(entry: Path, key: str, name: str) -> bool:
    try:
        marker = json.loads((entry / MARKER).read_text(encoding="utf-8"))
        library = entry / _library_name(name)
        return marker.get("key") == key and marker.get("sha256") == _sha256_file(library)
    except (OSError, ValueError):
        return False


def _discard(path: Path) -> None:
    """Move an entry out of the way (rename is atomic), then delete it."""
    if not path.exists():
        return
    aside = path.with_name(f".stale-{path.name[:16]}-{uuid.uuid4().hex[:8]}")
    try:
        os.rename(path, aside)
    except OSError:
        aside = path
    shutil.rmtree(aside, ignore_errors=True)


def host_tag() -> str:
    """Short tag of this machine: a cache folder may be shared, and a pid means something only on the
    machine that made the folder."""
    import socket

    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def new_build_folder(root: Path, key: str) -> Path:
    """A fresh build folder ``.build-<key>-<host>-<pid>-<random>`` in ``root``: its owner can be told
    dead or alive by :func:`remove_stale_builds`."""
    return Path(tempfile.mkdtemp(prefix=f"{BUILD_PREFIX}{key[:12]}-{host_tag()}-{os.getpid()}-", dir=root))


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists, owned by someone else
    return True


def remove_stale_builds(root: Path) -> None:
    """Remove build folders that no build in progress owns: made on this machine by a process that
    is gone (a compile killed part-way, a SIGKILL), or older than :data:`STALE_BUILD_S` (also the
    ``.gen-`` folders of generated models and the ``.stale-`` entries being deleted)."""
    try:
        folders = [p for p in root.iterdir() if p.name.startswith((BUILD_PREFIX, ".stale-", ".gen-"))]
    except OSError:
        return
    host, now = host_tag(), time.time()
    for folder in folders:
        parts = folder.name[len(BUILD_PREFIX) :].split("-")
        dead = (
            folder.name.startswith(BUILD_PREFIX)
            and len(parts) >= 4
            and parts[1] == host
            and parts[2].isdigit()
            and not pid_alive(int(parts[2]))
        )
        try:
            old = now - folder.stat().st_mtime > STALE_BUILD_S
        except OSError:
            continue
        if dead or old:
            shutil.rmtree(folder, ignore_errors=True)


def _compile(
    cc: list[str], flags: Sequence[str], sources: Mapping[str, bytes], build: Path, name: str
) -> None:
    for filename, data in sources.items():
        (build / filename).write_bytes(data)
    c_files = [f for f in sources if f.endswith(".c")]
    command = [*cc, *flags, "-o", _library_name(name), *c_files, "-lm"]
    try:
        done = subprocess.run(
            command, cwd=build, capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.SubprocessError) as exc:
        raise CompilerError(f"cannot run the C compiler {shlex.join(command)!r}: {exc}") from exc
    library = build / _library_name(name)
    if done.returncode != 0 or not library.is_file():
        raise CompilerError(
            f"C compiler failed (exit {done.returncode}): {shlex.join(command)}\n{done.stderr[-4000:]}"
        )


def build_library(
    sources: Mapping[str, bytes],
    name: str,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    flags: Sequence[str] = DEFAULT_FLAGS,
    rebuild: bool = False,
) -> Path:
    """Compile ``sources`` (``{file name: bytes}``) into a cached shared library; return its path.

    Reuses a valid cache entry; an invalid one (marker or library hash mismatch) is rebuilt.
    Raises :class:`CompilerError` when the compiler is missing or fails.
    """
    cc = compiler_command()
    h = hashlib.sha256()
    for part in (shlex.join(cc), _compiler_identity(tuple(cc)), shlex.join(flags), name):
        h.update(part.encode() + b"\0")
    for filename, data in sorted(sources.items()):
        h.update(filename.encode() + b"\0" + hashlib.sha256(data).digest())
    key = h.hexdigest()

    root = cache_root(cache_dir)
    entry = root / key
    if not rebuild and _valid_entry(entry, key, name):
        return entry / _library_name(name)

    remove_stale_builds(root)
    build = new_build_folder(root, key)
    try:
        _compile(cc, flags, sources, build, name)
        marker = {
            "key": key,
            "sha256": _sha256_file(build / _library_name(name)),
            "compiler": shlex.join(cc),
            "flags": list(flags),
            "sources": sorted(sources),
        }
        (build / MARKER).write_text(json.dumps(marker, indent=1), encoding="utf-8")
        if entry.exists():
            if not rebuild and _valid_entry(entry, key, name):  # another process won the race
                return entry / _library_name(name)
            _discard(entry)
        try:
            os.rename(build, entry)
        except OSError:
            if not _valid_entry(entry, key, name):
                raise
    finally:
        if build.exists():
            shutil.rmtree(build, ignore_errors=True)
    return entry / _library_name(name)


def load_library(
    sources: Mapping[str, bytes],
    name: str,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    flags: Sequence[str] = DEFAULT_FLAGS,
) -> ctypes.CDLL:
    """:func:`build_library` then ``dlopen``; a library that ``dlopen`` rejects is rebuilt once."""
    path = build_library(sources, name, cache_dir=cache_dir, flags=flags)
    try:
        return ctypes.CDLL(str(path))
    except OSError as first:
        path = build_library(sources, name, cache_dir=cache_dir, flags=flags, rebuild=True)
        try:
            return ctypes.CDLL(str(path))
        except OSError as exc:
            raise CompilerError(f"cannot load the freshly built library {path}: {exc}") from first


# ---------------------------------------------------------------------------------------------
# Kernels
# ---------------------------------------------------------------------------------------------


@dataclass
class _KernelMeta:
    name: str
    symbol: str
    doc: str
    input_names: list[str]
    input_sizes: list[int]
    output_names: list[str]
    output_shapes: list[tuple[int, int]]
    casadi_file: str

    @classmethod
    def from_manifest(cls, entry: dict[str, Any]) -> _KernelMeta:
        return cls(
            name=entry["name"],
            symbol=entry["symbol"],
            doc=entry["doc"],
            input_names=[i["name"] for i in entry["inputs"]],
            input_sizes=[int(i["size"]) for i in entry["inputs"]],
            output_names=[o["name"] for o in entry["outputs"]],
            output_shapes=[(int(o["rows"]), int(o["cols"])) for o in entry["outputs"]],
            casadi_file=entry["casadi_file"],
        )


class Kernel:
    """A callable kernel: ``kernel(*inputs) -> ndarray`` (one output) or a tuple of ndarrays.

    Inputs are array-likes of the sizes in ``input_sizes`` (scalars are fine for size 1); outputs
    are dense float64 arrays of the shapes in ``output_shapes``.
    """

    backend = ""

    def __init__(self, meta: _KernelMeta) -> None:
        self.meta = meta
        self.name = meta.name
        self.doc = meta.doc
        self.input_names = meta.input_names
        self.input_sizes = meta.input_sizes
        self.output_names = meta.output_names
        self.output_shapes = meta.output_shapes

    def _check_inputs(self, args: Sequence[Any]) -> list[np.ndarray]:
        if len(args) != len(self.input_sizes):
            raise TypeError(
                f"kernel {self.name!r} takes {len(self.input_sizes)} inputs "
                f"({', '.join(self.input_names)}), got {len(args)}"
            )
        arrays = []
        for name, size, value in zip(self.input_names, self.input_sizes, args, strict=True):
            array = np.asarray(value, dtype=np.float64).reshape(-1)
            if array.size != size:
                raise ValueError(
                    f"kernel {self.name!r}: input {name!r} needs {size} values, got {array.size}"
                )
            arrays.append(array)
        return arrays

    def _result(self, outputs: list[np.ndarray]) -> np.ndarray | tuple[np.ndarray, ...]:
        return outputs[0] if len(outputs) == 1 else tuple(outputs)

    def call_dict(self, *args: Any) -> dict[str, np.ndarray]:
        """Like calling the kernel, but returns ``{output name: array}``."""
        result = self(*args)
        values = (result,) if isinstance(result, np.ndarray) else result
        return dict(zip(self.output_names, values, strict=True))

    def __call__(self, *args: Any) -> np.ndarray | tuple[np.ndarray, ...]:  # pragma: no cover
        raise NotImplementedError

    def __repr__(self) -> str:
        ins = ", ".join(f"{n}[{s}]" for n, s in zip(self.input_names, self.input_sizes, strict=True))
        outs = ", ".join(f"{n}{s}" for n, s in zip(self.output_names, self.output_shapes, strict=True))
        return f"<{self.backend} kernel {self.name}({ins}) -> ({outs})>"


def _parse_sparsity(pointer: Any) -> tuple[int, int, np.ndarray, np.ndarray]:
    """Rows and columns of the nonzeros of a CasADi compressed pattern (``[nrow, ncol, ...]``)."""
    nrow, ncol = int(pointer[0]), int(pointer[1])
    if int(pointer[2]) == 1:
        # Compact dense form [nrow, ncol, 1]: a real colind always starts with 0.
        rows = np.tile(np.arange(nrow), ncol)
        cols = np.repeat(np.arange(ncol), nrow)
        return nrow, ncol, rows, cols
    colind = [int(pointer[2 + j]) for j in range(ncol + 1)]
    nnz = colind[-1]
    rows = np.array([int(pointer[3 + ncol + k]) for k in range(nnz)], dtype=np.intp)
    cols = np.repeat(np.arange(ncol), np.diff(colind))
    return nrow, ncol, rows, cols


class CKernel(Kernel):
    """A kernel evaluated by the compiled C library through ctypes."""

    backend = "c"

    def __init__(self, meta: _KernelMeta, library: ctypes.CDLL, int_type: type) -> None:
        super().__init__(meta)
        self._library = library  # keeps the library loaded while the kernel lives
        # A fresh function pointer without argtypes, called with prebuilt ctypes arguments: this
        # skips ctypes' per-call argument conversion (about 3x faster for small kernels).
        fn = library[meta.symbol]
        fn.restype = ctypes.c_int
        self._fn = fn

        sizes = [int_type() for _ in range(4)]
        work = library[f"{meta.symbol}_work"]
        work.argtypes = [ctypes.POINTER(int_type)] * 4
        work.restype = ctypes.c_int
        work(*[ctypes.byref(s) for s in sizes])
        sz_arg, sz_res, sz_iw, sz_w = (int(s.value) for s in sizes)

        sparsity_in = library[f"{meta.symbol}_sparsity_in"]
        sparsity_out = library[f"{meta.symbol}_sparsity_out"]
        for f in (sparsity_in, sparsity_out):
            f.argtypes = [int_type]
            f.restype = ctypes.POINTER(int_type)
        for i, size in enumerate(meta.input_sizes):
            nrow, ncol, _, _ = _parse_sparsity(sparsity_in(i))
            if nrow * ncol != size:
                raise CompilerError(f"kernel {meta.name}: library and manifest disagree on input {i}")
        self._scatter = []
        self._out = []
        for i, shape in enumerate(meta.output_shapes):
            nrow, ncol, rows, cols = _parse_sparsity(sparsity_out(i))
            if (nrow, ncol) != shape:
                raise CompilerError(f"kernel {meta.name}: library and manifest disagree on output {i}")
            self._scatter.append(rows * ncol + cols)
            self._out.append(np.zeros(len(rows)))

        self._in = [np.zeros(size) for size in meta.input_sizes]
        np_int = np.int32 if ctypes.sizeof(int_type) == 4 else np.int64
        self._iw = np.zeros(max(sz_iw, 1), dtype=np_int)
        self._w = np.zeros(max(sz_w, 1))
        arg_ptrs = [a.ctypes.data for a in self._in] + [None] * (sz_arg - len(self._in))
        res_ptrs = [o.ctypes.data for o in self._out] + [None] * (sz_res - len(self._out))
        self._arg = (ctypes.c_void_p * max(sz_arg, 1))(*arg_ptrs)
        self._res = (ctypes.c_void_p * max(sz_res, 1))(*res_ptrs)
        self._call_args = (
            self._arg,
            self._res,
            ctypes.c_void_p(self._iw.ctypes.data),
            ctypes.c_void_p(self._w.ctypes.data),
            ctypes.c_int(0),
        )

    def __call__(self, *args: Any) -> np.ndarray | tuple[np.ndarray, ...]:
        for buffer, value in zip(self._in, self._check_inputs(args), strict=True):
            np.copyto(buffer, value)
        status = self._fn(*self._call_args)
        if status != 0:
            raise RuntimeError(f"kernel {self.name!r} returned status {status}")
        outputs = []
        for nz, index, (rows, cols) in zip(self._out, self._scatter, self.output_shapes, strict=True):
            dense = np.zeros(rows * cols)
            dense[index] = nz
            outputs.append(dense.reshape(rows, cols))
        return self._result(outputs)


class CasadiKernel(Kernel):
    """A kernel evaluated by CasADi's virtual machine from the serialized ``.casadi`` Function."""

    backend = "casadi"

    def __init__(self, meta: _KernelMeta, function: Any) -> None:
        super().__init__(meta)
        self.function = function

    def __call__(self, *args: Any) -> np.ndarray | tuple[np.ndarray, ...]:
        result = self.function.call(self._check_inputs(args))
        return self._result([np.array(r.full(), dtype=np.float64) for r in result])


@dataclass
class ModelKernels:
    """The kernels of one model. Kernels are attributes (``k.mass_matrix``) and items (``k["..."]``)."""

    name: str
    backend: str
    folder: Path
    parameters: list[str]
    defaults: np.ndarray
    sizes: dict[str, int]
    kernels: dict[str, Kernel] = field(repr=False)

    def __getattr__(self, name: str) -> Kernel:
        kernels = self.__dict__.get("kernels", {})
        if name in kernels:
            return kernels[name]
        raise AttributeError(f"model {self.__dict__.get('name')!r} has no kernel {name!r}")

    def __getitem__(self, name: str) -> Kernel:
        return self.kernels[name]

    def __iter__(self):  # noqa: ANN204 - iterator of kernel names
        return iter(self.kernels)

    def parameter_vector(self, overrides: Mapping[str, float] | None = None) -> np.ndarray:
        """The default parameter vector with ``overrides`` (by name) applied."""
        values = self.defaults.copy()
        for key, value in (overrides or {}).items():
            if key not in self.parameters:
                raise KeyError(f"model {self.name!r} has no parameter {key!r}; it has {self.parameters}")
            values[self.parameters.index(key)] = float(value)
        return values


def generated_root() -> Path:
    """The package's ``generated/`` folder (committed code of the built-in models)."""
    return Path(str(resources.files("svbi.generated")))


def model_folder(model: Any, *, cache_dir: str | os.PathLike[str] | None = None) -> Path:
    """The folder holding a model's generated files.

    ``model`` is a built-in model name, a folder written by ``svbi generate``, a topology file, or a
    ``ModelSpec``. Topology files and specs are generated into the cache (``<cache>/models/<hash>``).
    """
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ..codegen.kernels import ModelSpec

    if isinstance(model, ModelSpec):
        return _generate_into_cache(model, cache_dir)
    path = Path(model)
    if path.is_dir() and (path / MANIFEST).is_file():
        return path
    builtin = generated_root() / str(model)
    if (builtin / MANIFEST).is_file():
        return builtin
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ..codegen.kernels import model_spec

    return _generate_into_cache(model_spec(model), cache_dir)


def _generate_into_cache(spec: Any, cache_dir: str | os.PathLike[str] | None) -> Path:
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ..codegen import c_emit

    files = c_emit.render_model(spec)
    digest = json.loads(files[MANIFEST])["inputs_sha256"]
    root = cache_root(cache_dir) / "models"
    root.mkdir(parents=True, exist_ok=True)
    final = root / digest
    if (final / MANIFEST).is_file() and all(
        (final / n).is_file() and (final / n).read_bytes() == d for n, d in files.items()
    ):
        return final
    remove_stale_builds(root)
    build = Path(tempfile.mkdtemp(prefix=".gen-", dir=root))
    c_emit.write_files(files, build)
    _discard(final)
    try:
        os.rename(build, final)
    except OSError:
        shutil.rmtree(build, ignore_errors=True)
    return final


def _int_type(size: int) -> type:
    return {4: ctypes.c_int32, 8: ctypes.c_int64}[size]


def load_kernels(
    model: Any,
    backend: str = "c",
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    flags: Sequence[str] = DEFAULT_FLAGS,
) -> ModelKernels:
    """Callable kernels of a model (see the module docstring).

    ``backend`` is ``"c"`` (compiled; falls back to ``"casadi"`` with a warning when no C compiler
    works) or ``"casadi"``. The returned object's ``backend`` says which one is in use.
    """
    if backend not in ("c", "casadi"):
        raise ValueError(f"backend must be 'c' or 'casadi', got {backend!r}")
    folder = model_folder(model, cache_dir=cache_dir)
    manifest = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    metas = [_KernelMeta.from_manifest(k) for k in manifest["kernels"]]

    kernels: dict[str, Kernel] | None = None
    used = backend
    if backend == "c":
        sources = {n: (folder / n).read_bytes() for n in [*manifest["sources"], *manifest["headers"]]}
        try:
            library = load_library(sources, f"svbi_{manifest['c_name']}", cache_dir=cache_dir, flags=flags)
        except CompilerError as exc:
            _warn_once(
                f"compiler:{shlex.join(compiler_command())}",
                f"svbi: no working C compiler ({exc}); using the CasADi backend instead, which is "
                "slower. Install a C compiler or set CC to use compiled kernels.",
                BackendFallbackWarning,
            )
            used = "casadi"
        else:
            size_fn = library[f"svbi_{manifest['c_name']}_cg_casadi_int_size"]
            size_fn.restype = ctypes.c_int
            int_type = _int_type(size_fn())
            kernels = {m.name: CKernel(m, library, int_type) for m in metas}
    if kernels is None:
        import casadi

        kernels = {
            m.name: CasadiKernel(
                m, casadi.Function.deserialize((folder / m.casadi_file).read_text(encoding="ascii"))
            )
            for m in metas
        }
    return ModelKernels(
        name=manifest["model"],
        backend=used,
        folder=folder,
        parameters=[p["name"] for p in manifest["parameters"]],
        defaults=np.array([p["default"] for p in manifest["parameters"]], dtype=np.float64),
        sizes=dict(manifest["sizes"]),
        kernels=kernels,
    )


# --------------------------------------------------------------------------------------------------
# generated NumPy modules of topology files (svbi.codegen.python_emit)


def _codegen_digest() -> str:
    """sha256 of the code generator's sources and the SymPy version: a cached module generated by an
    older generator is never reused."""
    from importlib import metadata

    h = hashlib.sha256(f"sympy {metadata.version('sympy')}\n".encode())
    folder = Path(str(resources.files("svbi.codegen")))
    for path in sorted(folder.rglob("*")):
        if path.suffix in (".py", ".toml") and "__pycache__" not in path.parts:
            h.update(path.relative_to(folder).as_posix().encode() + b"\n" + path.read_bytes())
    return h.hexdigest()


def python_module(
    topology: str | os.PathLike[str], *, cache_dir: str | os.PathLike[str] | None = None
) -> Path:
    """The generated NumPy module of a topology file, derived and emitted once into the cache.

    The entry ``<cache>/python/<sha256>/numpy_kernels.py`` is keyed by the file's content and the
    generator (:func:`_codegen_digest`), not by its path: later runs only load it. It is written to a
    temporary file and renamed into place, so a concurrent run never reads half a module.
    """

    text = Path(topology).read_bytes()
    key = hashlib.sha256(b"svbi python kernels\n" + _codegen_digest().encode() + b"\n" + text).hexdigest()
    final = cache_root(cache_dir) / "python" / key / PYTHON_KERNELS_FILE
    if final.is_file():
        return final
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ..codegen.python_emit import render_target

    _, source = render_target(str(topology))
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{uuid.uuid4().hex}.tmp")
    tmp.write_bytes(source)
    os.replace(tmp, final)
    return final


def python_module_3d(
    topology: str | os.PathLike[str] | None = None,
    *,
    text: str | None = None,
    source: str = "<string>",
    cache_dir: str | os.PathLike[str] | None = None,
) -> Path:
    """The generated NumPy module of a 3D topology file (or of its TOML ``text``, errors naming
    ``source``), derived and emitted once into the cache as :func:`python_module` does for a 2D file:
    keyed by the content and the generator, written atomically."""
    if topology is None and text is None:
        raise ValueError("python_module_3d needs a topology file or its text")
    data = Path(topology).read_bytes() if topology is not None else str(text).encode()
    key = hashlib.sha256(b"svbi python kernels 3d\n" + _codegen_digest().encode() + b"\n" + data).hexdigest()
    final = cache_root(cache_dir) / "python" / key / PYTHON_KERNELS_FILE
    if final.is_file():
        return final
    # deferred: brings SymPy, for derivation and emission only
    from ..codegen.vehicle3d import render_vehicle3d, render_vehicle3d_text

    rendered = (
        render_vehicle3d(str(topology))[1]
        if topology is not None
        else render_vehicle3d_text(str(text), source)
    )
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{uuid.uuid4().hex}.tmp")
    tmp.write_bytes(rendered)
    os.replace(tmp, final)
    return final


def load_topology3d(name_or_path: str | os.PathLike[str]) -> Any:
    """The parsed 3D topology (:class:`svbi.codegen.topology3d.Topology3D`) of a built-in 3D
    vehicle's name or a 3D topology file. Deferred: the parser brings SymPy (its expressions); a 3D
    scenario's checks and defaults take a built-in vehicle's parameters from its generated module
    instead (:func:`svbi.runtime.model.system3d.vehicle_parameters3d`), a file's from here."""
    from ..codegen.topology3d import load_topology3d as load

    return load(name_or_path)
