"""`twmr compare a/x.yaml b/x.yaml`: each scenario keeps its own name (and results folder), the
stem with as many folders as tell them apart; the same file twice is refused."""
from __future__ import annotations

from pathlib import Path

import pytest

from twmr.components.compare import labels
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(30)


def test_scenarios_of_one_stem_get_names_apart(tmp_path: Path) -> None:
    paths = [tmp_path / "a" / "x.yaml", tmp_path / "b" / "x.yaml", tmp_path / "y.yaml"]
    assert labels(paths) == ["a/x", "b/x", f"{tmp_path.name}/y"]
    assert labels([tmp_path / "x.yaml", tmp_path / "y.yaml"]) == ["x", "y"]
    deep = [tmp_path / "p" / "s" / "x.yaml", tmp_path / "q" / "s" / "x.yaml"]
    assert labels(deep) == ["p/s/x", "q/s/x"]


def test_the_same_file_twice_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CosimError, match="is given twice"):
        labels([tmp_path / "x.yaml", tmp_path / "." / "x.yaml"])
