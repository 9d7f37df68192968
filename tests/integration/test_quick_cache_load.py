"""Machine code read back from numba's cache without numba's registries
(`twmr.master.schedule_cache.quick_loader`): in a fresh process, a function that allocates
(numba's runtime, NRT_*) and hashes a tuple (the hash secrets' symbols) is read back (a cache
hit) and gives what the process that compiled it gave; the paper's robot, run compiled from a
warm cache in a fresh process, gives the rows of the Python schedule without importing numba's
lowering registries (which numba's own load would: `numba.np.linalg`, with scipy)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import twmr

pytestmark = pytest.mark.timeout(600)
ROOT = Path(__file__).resolve().parents[2]

MODULE = '''
import numpy as np
from numba import njit


@njit(cache=True)
def mixed(x):
    a = np.zeros(3)
    a[1] = x
    return hash((x, 2.0)) % 1000003 + a.sum()
'''

FIRST = '''
import json, sys
sys.path.insert(0, sys.argv[1])
import mixed_mod
print(json.dumps(mixed_mod.mixed(1.5)))
'''

SECOND = '''
import json, sys
sys.path.insert(0, sys.argv[1])
import mixed_mod
from twmr.master.schedule_cache import quick_loader
fn = mixed_mod.mixed
fn._cache.load_overload = quick_loader(fn._cache)
from numba import float64
fn.compile((float64,))  # the key the first process cached it under: the argument types
hits = sum(fn.stats.cache_hits.values())
print(json.dumps([fn(1.5), hits]))
'''


def python(code: str, *args: str, env: dict[str, str] | None = None) -> str:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args],
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().splitlines()[-1]


def test_cached_code_that_allocates_and_hashes_loads_without_the_registries(tmp_path) -> None:
    (tmp_path / "mixed_mod.py").write_text(MODULE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    compiled = json.loads(python(FIRST, str(tmp_path), env=env))
    value, hits = json.loads(python(SECOND, str(tmp_path), env=env))
    assert hits == 1  # read back, not compiled again
    assert value == compiled


def test_the_paper_run_from_a_warm_cache_skips_the_registries(tmp_path) -> None:
    scenario = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    env = {**os.environ, "TWMR_CACHE_DIR": str(tmp_path / "cache")}
    run = [sys.executable, "-m", "twmr.cli", "run", str(scenario), "--compiled", "on", "--set",
           "experiment.stop=2", "-q"]
    first = subprocess.run([*run, "--out", str(tmp_path / "a")], capture_output=True,
                           text=True, timeout=500, env=env)
    assert first.returncode == 0, first.stderr
    probe = f'''
import sys, runpy
sys.argv = {[*run[2:], "--out", str(tmp_path / "b")]!r}
try:
    runpy.run_module("twmr.cli", run_name="__main__")
except SystemExit as exc:
    assert not exc.code, exc.code
print("numba.np.linalg" in sys.modules)
'''
    assert python(probe, env=env) == "False"
    warm = twmr.read_result(tmp_path / "b")
    assert warm.summary["pacing"]["algorithm.compiled"] is True
    reference = twmr.simulate(twmr.load(scenario, ["experiment.stop=2"]), None,
                              options=twmr.Options(compiled="off"))
    np.testing.assert_array_equal(warm.values, reference.values)
