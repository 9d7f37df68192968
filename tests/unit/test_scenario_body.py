"""`body:` on a component: the scenario describes the vehicle a pose output moves (for a robot
in an FMU, or to draw another robot), in place of what the block says; a port that is no pose,
a key that is no dimension and a body on a subsystem are refused at their line."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

import twmr
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(120)
ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"


def _with_body(tmp_path: Path, body: object, name: str = "plant") -> Path:
    data = yaml.safe_load(PAPER.read_text(encoding="utf-8"))
    data["components"][name]["body"] = body
    data["experiment"]["stop"] = 0.05
    path = tmp_path / "bodied.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def test_the_scenarios_body_replaces_the_blocks(tmp_path: Path) -> None:
    path = _with_body(tmp_path, {"pose": {"wheel_radius": 0.05, "half_track": 0.2,
                                          "ahead": 0.1}})
    result = twmr.simulate(twmr.load(path), tmp_path / "run")
    body = result.summary["ports"]["plant.pose"]["body"]
    assert body == {"wheel_radius": 0.05, "half_track": 0.2, "length": 0.4,
                    "width": pytest.approx(0.32), "height": 0.05, "ahead": 0.1}
    plain = twmr.simulate(twmr.load(PAPER, ["experiment.stop=0.05"]))
    assert plain.summary["ports"]["plant.pose"]["body"]["wheel_radius"] == 0.15  # the block's


@pytest.mark.parametrize(("body", "said"), [
    ({"com": {"wheel_radius": 0.1, "half_track": 0.2}},
     "body: 'com' is not a planar pose it outputs"),
    ({"pose": {"radius": 0.1, "half_track": 0.2}}, "radius"),
    ({"pose": {"wheel_radius": -1, "half_track": 0.2}}, "wheel_radius"),
])
def test_a_body_that_cannot_be_is_refused_at_its_line(tmp_path: Path, body: object,
                                                      said: str) -> None:
    path = _with_body(tmp_path, body)
    with pytest.raises(ScenarioError) as caught:
        twmr.load(path)
    text = str(caught.value)
    assert said in text and "bodied.yaml:" in text and "Fix:" in text
    line = int(text.split("bodied.yaml:")[1].split(" ")[0].split(":")[0])
    assert line > path.read_text().splitlines().index("    body:")  # at the body, not before


def test_a_body_on_a_subsystem_is_refused(tmp_path: Path) -> None:
    nested = ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml"
    data = yaml.safe_load(nested.read_text(encoding="utf-8"))
    data["components"]["robot"]["body"] = {"pose": {"wheel_radius": 0.1, "half_track": 0.2}}
    data["components"]["robot"]["parameters"]["path"] = str(
        nested.parent / data["components"]["robot"]["parameters"]["path"])
    path = tmp_path / "nested.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"'robot' is a subsystem.*body"):
        twmr.load(path)
