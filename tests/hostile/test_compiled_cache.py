"""A hostile compiled-loop cache (`TWMR_CACHE_DIR`): a cached `kind_<hash>.py` (the adapters of a
kind of block, `twmr.master.driver`) with one sign flipped or a line prepended, and numba's cache
of it (`__pycache__/*.nbi`, `*.nbc`) corrupted.
Each run still gives the results of a fresh compile, runs nothing that was put there, says what it
found, and recompiles instead of blaming the kernel."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.hostile.runner import GOOD_TEXT, Outcome, assert_ok, run_cli, write


def compiled_run(cwd: Path, cache: Path, out: str) -> tuple[Outcome, twmr.Result]:
    env = {**os.environ, "TWMR_CACHE_DIR": str(cache)}
    o = run_cli(["run", "loop.yaml", "--compiled", "on", "--set", "experiment.stop=2",
                 "--out", out], cwd, timeout=240, env=env)
    assert_ok(o)
    result = twmr.read_result(cwd / out)
    assert result.summary["pacing"]["algorithm.compiled"] is True
    return o, result


@pytest.fixture(scope="module")
def fresh(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, twmr.Result]:
    """A cache filled by one compiled run, and that run's result."""
    base = tmp_path_factory.mktemp("cache")
    write(base, "loop.yaml", GOOD_TEXT)
    _, result = compiled_run(base, base / "cache", "first")
    assert list((base / "cache").glob("kind_*.py"))
    assert list((base / "cache" / "__pycache__").glob("*.nbc"))
    return base / "cache", result


@pytest.fixture
def cache(fresh: tuple[Path, twmr.Result], tmp_path: Path) -> Path:
    write(tmp_path, "loop.yaml", GOOD_TEXT)
    shutil.copytree(fresh[0], tmp_path / "cache")  # copy2: numba's stamps stay valid
    return tmp_path / "cache"


def same_rows(result: twmr.Result, expected: twmr.Result) -> None:
    assert result.columns == expected.columns
    np.testing.assert_array_equal(result.values, expected.values)


def test_a_flipped_sign_in_the_cached_loop_is_recompiled(fresh, cache: Path) -> None:
    module = sorted(cache.glob("kind_*.py"))[0]
    original = module.read_text()
    assert " + " in original
    module.write_text(original.replace(" + ", " - ", 1))
    o, result = compiled_run(cache.parent, cache, "again")
    same_rows(result, fresh[1])
    assert "differs from the loop generated now" in o.stderr and module.name in o.stderr
    assert module.read_text() == original


def test_a_line_prepended_to_the_cached_loop_does_not_run(fresh, cache: Path) -> None:
    module = sorted(cache.glob("kind_*.py"))[0]
    marker = cache.parent / "ran.txt"
    module.write_text(f"open({str(marker)!r}, 'w').write('ran')\n" + module.read_text())
    o, result = compiled_run(cache.parent, cache, "again")
    assert not marker.exists(), "a line put into the cache ran"
    same_rows(result, fresh[1])
    assert "differs from the loop generated now" in o.stderr


@pytest.mark.parametrize("suffix", ["nbi", "nbc"])
def test_a_corrupt_numba_cache_is_recompiled_not_blamed_on_the_kernel(fresh, cache: Path,
                                                                      suffix: str) -> None:
    files = sorted((cache / "__pycache__").glob(f"*.{suffix}"))
    assert files
    for f in files:
        data = f.read_bytes()
        f.write_bytes(data[: len(data) // 2] + b"\x00garbage")
    o, result = compiled_run(cache.parent, cache, "again")
    same_rows(result, fresh[1])
    assert "numba's cache of" in o.stderr and "compiling it again" in o.stderr
    assert "correct the kernel" not in o.stderr
    o, result = compiled_run(cache.parent, cache, "third")  # the new cache is used as is
    same_rows(result, fresh[1])
    assert "numba's cache of" not in o.stderr


def test_a_purge_spares_the_cache_another_process_recorded_meanwhile(tmp_path: Path) -> None:
    """The check found a file not recorded; by the time this process holds the lock to purge,
    another has recorded the set: the purge leaves it (no recompiling what is sound). A set still
    not recorded, or one numba could not read, goes."""
    from twmr.master.schedule_cache import _VerifiedCache

    module = tmp_path / "schedule_abc.py"
    module.write_text("", encoding="utf-8")
    cache = _VerifiedCache(module, [])
    cache.folders = {tmp_path}
    files = [tmp_path / "schedule_abc.run-3.py311.nbi", tmp_path / "schedule_abc.run-3.py311.1.nbc"]
    for f in files:
        f.write_bytes(b"numba's bytes")
    why = cache._mismatch()
    assert "is not recorded" in why
    cache._record()  # the other process, between the check and the purge
    cache._purge(why, unless_mended=True)
    assert all(f.exists() for f in files) and cache.manifest.exists()
    cache._purge("numba could not read it", unless_mended=False)
    assert not any(f.exists() for f in files) and not cache.manifest.exists()
    files[0].write_bytes(b"unrecorded")
    cache._purge(cache._mismatch(), unless_mended=True)
    assert not files[0].exists()
