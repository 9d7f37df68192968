"""Two runs into one results folder at once: the second is refused naming the first (its result
would silently replace the other's); after the first ends the folder is free again."""
from __future__ import annotations

from pathlib import Path

import pytest

import twmr
from twmr.api import _lock_folder
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(60)

SCENARIO = {"components": {"c": {"kind": "constant", "parameters": {"value": 1.0}}},
            "experiment": {"stop": 0.05, "step": 0.01}}


def test_a_second_run_into_a_folder_in_use_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "run"
    held = _lock_folder(out)  # another run, as it holds the folder
    try:
        with pytest.raises(CosimError, match="is in use by another run") as info:
            twmr.simulate(SCENARIO, out=str(out))
        assert '"pid"' in str(info.value) and "give another --out" in str(info.value)
        assert not out.exists()
    finally:
        held.close()
        (tmp_path / ".run.lock").unlink()
    result = twmr.simulate(SCENARIO, out=str(out))
    assert len(result.to_pandas()) == 6 and (out / "result.arrows").is_file()
    twmr.simulate(SCENARIO, out=str(out))  # a later run replaces it, as before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no lock left beside it
