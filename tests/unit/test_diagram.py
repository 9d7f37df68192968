"""`twmr diagram`: the SVG holds every block once with its step number and its ports with units,
every wire between the right ports, the wires of an algebraic loop marked, a subsystem's blocks
inside its frame, text from the scenario escaped, and a user's block not imported unasked."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from twmr.api import load
from twmr.cli import main
from twmr.diagram import diagram_svg

ROOT = Path(__file__).resolve().parents[2]
NS = {"s": "http://www.w3.org/2000/svg"}


def svg_of(path: Path) -> tuple[ET.Element, object]:
    system = load(path).system
    return ET.fromstring(diagram_svg(system, title=path.name)), system


def blocks(root: ET.Element) -> dict[str, ET.Element]:
    return {g.get("data-name"): g for g in root.iter("{http://www.w3.org/2000/svg}g")
            if g.get("class") == "block"}


def wires(root: ET.Element) -> list[ET.Element]:
    return [p for p in root.iter("{http://www.w3.org/2000/svg}path")
            if "wire" in (p.get("class") or "").split()]


def test_every_block_port_and_wire_of_the_sensor_scenario() -> None:
    root, system = svg_of(ROOT / "scenarios" / "paper_trajectory1_asmc_sensors.yaml")
    found = blocks(root)
    assert set(found) == set(system.components)  # type: ignore[attr-defined]
    assert [found[n].get("data-step") for n in system.order] == [  # type: ignore[attr-defined]
        str(k + 1) for k in range(len(system.order))]  # type: ignore[attr-defined]
    texts = "".join(found["ctrl"].itertext())
    assert "torque[2] [N.m]" in texts and "pose[3] [m, rad]" in texts
    drawn = sorted((p.get("data-src"), p.get("data-dst")) for p in wires(root))
    assert drawn == sorted((f"{c.src}.{c.src_port}", f"{c.dst}.{c.dst_port}")
                           for c in system.connections)  # type: ignore[attr-defined]
    # the gyro's wire from the plant is forward; the pose back to the controller feeds back
    kinds = {(p.get("data-src"), p.get("data-dst")): p.get("class") for p in wires(root)}
    assert kinds[("plant.pose", "ctrl.pose")] == "wire feedback"
    assert kinds[("ref.position", "ctrl.ref_position")] == "wire"


def test_the_wires_of_an_algebraic_loop_are_marked() -> None:
    root, _ = svg_of(ROOT / "scenarios" / "examples" / "algebraic_loop.yaml")
    looped = {(p.get("data-src"), p.get("data-dst")) for p in wires(root)
              if "loop" in (p.get("class") or "").split()}
    assert looped == {("s.y", "f.u"), ("f.y", "k.u"), ("k.y", "s.u2")}


def test_a_subsystems_blocks_sit_in_its_frame() -> None:
    root, _ = svg_of(ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml")
    frames = {g.get("data-name"): g.find("s:rect", NS) for g in root.iter(
        "{http://www.w3.org/2000/svg}g") if g.get("class") == "subsystem"}
    assert list(frames) == ["robot"]
    frame = frames["robot"]
    assert frame is not None
    x0, y0 = float(frame.get("x", 0)), float(frame.get("y", 0))
    x1, y1 = x0 + float(frame.get("width", 0)), y0 + float(frame.get("height", 0))
    for name, g in blocks(root).items():
        body = g.find("s:rect", NS)
        assert body is not None
        bx, by = float(body.get("x", 0)), float(body.get("y", 0))
        inside = x0 <= bx and bx + float(body.get("width", 0)) <= x1 and y0 <= by <= y1
        assert inside == name.startswith("robot."), name


def test_a_closed_subsystem_is_one_block_with_the_ports_its_wires_cross(
        tmp_path: Path, capsys) -> None:
    """`--closed robot`: one block for the robot's three, its ports the inner ports that wires
    from outside reach (named from the subsystem), each crossing wire ending on that port's
    circle, no wire inside it drawn; an unknown name is refused naming the subsystems."""
    path = ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml"
    out = tmp_path / "closed.svg"
    assert main(["diagram", str(path), "--closed", "all", "--out", str(out)]) == 0
    root = ET.fromstring(out.read_text(encoding="utf-8"))
    found = {g.get("data-name"): g for g in root.iter("{http://www.w3.org/2000/svg}g")
             if (g.get("class") or "").startswith("block")}
    assert sorted(found) == ["ctrl", "ref", "robot"]
    robot = found["robot"]
    assert robot.get("class") == "block closed" and "subsystem of 3 blocks" in "".join(
        robot.itertext())
    circles = {g.get("data-port"): g.find("s:circle", NS) for g in robot.iter(
        "{http://www.w3.org/2000/svg}g") if "port" in (g.get("class") or "")}
    assert sorted(circles) == ["robot.motor.torque_command", "robot.plant.pose",
                               "robot.plant.wheel_speed"]
    labels = "".join(robot.itertext())
    assert "plant.pose[3] [m, rad]" in labels and "motor.torque_command[2] [N.m]" in labels
    system = load(path).system
    crossing = [c for c in system.connections  # type: ignore[attr-defined]
                if c.src.startswith("robot.") != c.dst.startswith("robot.")]
    drawn = wires(root)
    assert len(drawn) == len([c for c in system.connections  # type: ignore[attr-defined]
                              if not (c.src.startswith("robot.") and c.dst.startswith("robot."))])
    for c in crossing:
        end = c.dst if c.dst.startswith("robot.") else c.src
        port = c.dst_port if end == c.dst else c.src_port
        wire = next(w for w in drawn if w.get("data-src") == f"{c.src}.{c.src_port}"
                    and w.get("data-dst") == f"{c.dst}.{c.dst_port}")
        circle = circles[f"{end}.{port}"]
        assert circle is not None
        xy = f"{float(circle.get('cx', 0)):.1f},{float(circle.get('cy', 0)):.1f}"
        d = wire.get("d") or ""
        assert d.startswith(f"M{xy}") or d.endswith(xy), (c, d, xy)
    assert main(["diagram", str(path), "--closed", "robt", "--out", str(out)]) == 1
    said = capsys.readouterr().err
    assert "--closed robt" in said and "its subsystems: robot" in said and "Fix:" in said


def test_text_is_escaped_and_a_users_block_is_not_imported_unasked(tmp_path: Path,
                                                                     capsys) -> None:
    odd = tmp_path / "a<b>&c.yaml"
    odd.write_text((ROOT / "scenarios" / "examples" / "algebraic_loop.yaml").read_text())
    assert main(["diagram", str(odd), "--out", str(tmp_path / "d.svg")]) == 0
    root = ET.fromstring((tmp_path / "d.svg").read_text())
    assert "a<b>&c.yaml" in "".join(root.itertext())
    (tmp_path / "mine.py").write_text("raise SystemExit('imported')\n")
    (tmp_path / "mine.yaml").write_text("components:\n  m: {kind: 'mine.py:Block'}\n"
                                        "experiment: {stop: 1.0, step: 0.1}\n")
    assert main(["diagram", str(tmp_path / "mine.yaml")]) == 1
    err = capsys.readouterr().err
    assert "--trust-code" in err and "imported" not in err  # refused, not run
    assert main(["diagram", str(tmp_path / "mine.yaml"), "--trust-code"]) == 1
    assert "the code called exit ('imported')" in capsys.readouterr().err  # run when asked


def test_blocks_of_a_layer_are_ordered_so_that_wires_do_not_cross(tmp_path: Path) -> None:
    """a and b feed d and c, c stepping first: in step order the two wires would cross; the
    layout puts d level with a and c level with b."""
    path = tmp_path / "crossed.yaml"
    path.write_text("""
components:
  a: {kind: constant}
  b: {kind: constant}
  c: {kind: gain}
  d: {kind: gain}
connections:
  - b.y -> c.u
  - a.y -> d.u
experiment: {stop: 0.01, step: 0.001}
""", encoding="utf-8")
    system = load(path).system
    assert system.order.index("c") < system.order.index("d")  # type: ignore[attr-defined]
    root = ET.fromstring(diagram_svg(system))
    top = {n: float(g.find("s:rect", NS).get("y", 0))  # type: ignore[union-attr]
           for n, g in blocks(root).items()}
    assert top["a"] < top["b"] and top["d"] < top["c"], top
