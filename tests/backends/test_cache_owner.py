"""The compiled-code cache is private to its user.

svbi loads shared libraries from its cache: a folder that another user can write (the fallback
``/tmp/svbi-cache-<uid>``, created beforehand by someone else, mode 777) would let them run code as
the user. The fallback is used only if it belongs to the user and is closed to others (mode 0700);
otherwise a fresh private folder is used, and a warning says why. ``$XDG_CACHE_HOME`` is honoured.
"""

from __future__ import annotations

import os
import stat
import warnings
from pathlib import Path

import pytest

from svbi.runtime import toolchain


@pytest.fixture
def temp_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A private temporary folder standing for /tmp, and a cache path that cannot be created (under
    a regular file), so that the fallback is taken; the fallback is looked up afresh."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(toolchain.tempfile, "tempdir", str(tmp))
    monkeypatch.setattr(toolchain, "_fallbacks", {}, raising=False)
    monkeypatch.setattr(toolchain, "_warned", set())
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("SVBI_CACHE_DIR", str(blocker / "cache"))
    return tmp


def _private(folder: Path) -> bool:
    st = folder.lstat()
    return stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and stat.S_IMODE(st.st_mode) == 0o700


def _fallback(tmp: Path) -> Path:
    return tmp / f"svbi-cache-{os.getuid()}"


def test_the_fallback_is_created_private_and_reused(temp_root: Path) -> None:
    with pytest.warns(toolchain.CacheWarning, match="not writable"):
        root = toolchain.cache_root()
    assert root == _fallback(temp_root) and _private(root)
    assert toolchain.cache_root() == root  # the same folder for later calls


def test_a_fallback_open_to_other_users_is_not_used(temp_root: Path) -> None:
    planted = _fallback(temp_root)
    planted.mkdir()
    planted.chmod(0o777)  # as another user would leave it (or a user's own mistake)
    with pytest.warns(toolchain.CacheWarning) as caught:
        root = toolchain.cache_root()
    assert root != planted and _private(root)
    message = " ".join(str(w.message) for w in caught)
    assert str(planted) in message and "open to other users" in message
    assert stat.S_IMODE(planted.stat().st_mode) == 0o777  # left as it was, and never loaded from


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root to chown")
def test_a_fallback_that_belongs_to_another_user_is_not_used(temp_root: Path) -> None:
    planted = _fallback(temp_root)
    planted.mkdir(mode=0o700)
    os.chown(planted, 65534, 65534)  # nobody
    with pytest.warns(toolchain.CacheWarning) as caught:
        root = toolchain.cache_root()
    assert root != planted and _private(root)
    assert "belongs to another user" in " ".join(str(w.message) for w in caught)


def test_a_symbolic_link_as_the_fallback_is_not_followed(temp_root: Path, tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir(mode=0o700)
    _fallback(temp_root).symlink_to(elsewhere)
    with pytest.warns(toolchain.CacheWarning, match="symbolic link"):
        root = toolchain.cache_root()
    assert root not in (_fallback(temp_root), elsewhere) and _private(root)


def test_libraries_are_built_into_the_private_folder_not_the_planted_one(temp_root: Path) -> None:
    planted = _fallback(temp_root)
    planted.mkdir()
    planted.chmod(0o777)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", toolchain.CacheWarning)
        try:
            path = toolchain.build_library({"a.c": b"int f(void) { return 1; }\n"}, "probe")
        except toolchain.CompilerError:
            pytest.skip("no C compiler")
    assert planted not in path.parents
    assert list(planted.iterdir()) == []


def test_xdg_cache_home_is_honoured(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SVBI_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert toolchain.cache_root() == tmp_path / "xdg" / "svbi"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")  # the specification: ignored
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert toolchain.cache_root() == tmp_path / "home" / ".cache" / "svbi"
