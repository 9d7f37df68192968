"""Inclusion is bounded: 24 files each including the next twice (2^24 blocks) and a chain of 40
files are refused at check, quickly, with one clear error; a shallow one still loads. The same
for SSP systems of .ssd files including .ssd files."""
from __future__ import annotations

from pathlib import Path

import pytest

import twmr
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(120)

LEAF = "components:\n  g: {kind: gain}\ninputs: {u: g.u}\noutputs: {y: g.y}\n"
TOP = ("components:\n  c: {kind: constant, parameters: {value: 1.0}}\n"
       "  s: {kind: system, parameters: {path: f0.yaml}}\nconnections: [c.y -> s.u]\n"
       "experiment: {stop: 0.1, step: 0.01}\n")


def _files(folder: Path, depth: int, twice: bool) -> Path:
    for i in range(depth):
        nxt = f"f{i + 1}.yaml"
        if i == depth - 1:
            text = LEAF
        elif twice:
            text = (f"components:\n  a: {{kind: system, parameters: {{path: {nxt}}}}}\n"
                    f"  b: {{kind: system, parameters: {{path: {nxt}}}}}\n"
                    f"connections: [a.y -> b.u]\ninputs: {{u: a.u}}\noutputs: {{y: b.y}}\n")
        else:
            text = (f"components:\n  a: {{kind: system, parameters: {{path: {nxt}}}}}\n"
                    f"inputs: {{u: a.u}}\noutputs: {{y: a.y}}\n")
        (folder / f"f{i}.yaml").write_text(text)
    (folder / "top.yaml").write_text(TOP)
    return folder / "top.yaml"


def test_doubling_inclusions_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="more than 1,000 inclusions"):
        twmr.load(_files(tmp_path, 24, twice=True))


def test_a_chain_too_deep_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="more than 32 files deep"):
        twmr.load(_files(tmp_path, 40, twice=False))


def test_a_modest_nesting_loads(tmp_path: Path) -> None:
    scenario = twmr.load(_files(tmp_path, 6, twice=True))  # 2^5 gains
    assert len(scenario.system.components) == 1 + 32


def _ssd(name: str, elements: str) -> str:
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/'
            f'SystemStructureDescription" name="{name}" version="1.0">\n'
            f'  <ssd:System name="{name}">\n' +
            (f'    <ssd:Elements>\n{elements}    </ssd:Elements>\n' if elements else '') +
            '  </ssd:System>\n</ssd:SystemStructureDescription>\n')


def _ssd_files(folder: Path, depth: int, twice: bool) -> Path:
    """SystemStructure.ssd including l0.ssd; each l<i>.ssd includes l<i+1>.ssd (twice: as a
    and b); the last one holds an empty system."""
    def include(name: str, target: str) -> str:
        return (f'      <ssd:Component name="{name}" type="application/x-ssp-definition" '
                f'source="{target}"/>\n')

    for i in range(depth):
        nxt = f"l{i + 1}.ssd"
        body = "" if i == depth - 1 else include("a", nxt) + (include("b", nxt) if twice else "")
        (folder / f"l{i}.ssd").write_text(_ssd(f"l{i}", body))
    (folder / "SystemStructure.ssd").write_text(_ssd("top", include("s", "l0.ssd")))
    return folder


def test_doubling_ssd_inclusions_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"more than 1,000 \.ssd inclusions"):
        twmr.load(_ssd_files(tmp_path, 24, twice=True))


def test_an_ssd_chain_too_deep_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"more than 32 \.ssd files deep"):
        twmr.load(_ssd_files(tmp_path, 40, twice=False))
