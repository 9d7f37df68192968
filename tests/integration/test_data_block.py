"""The `data` block plays measured samples: a recorded run's torques played into the plant
give that run's rows bit for bit (Python and compiled loops), samples between the steps are
interpolated as numpy's `interp` does, and what cannot be played is refused naming file,
column and row."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(300)

PAPER = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
STOP = 1.5


def recorded(tmp_path: Path, decimation: int) -> tuple[Path, twmr.Result]:
    text = PAPER.read_text().replace("stop: 30.0", f"stop: {STOP}")
    text = text.replace("decimation: 10", f"decimation: {decimation}")
    (tmp_path / "closed.yaml").write_text(text)
    out = tmp_path / f"closed{decimation}"
    return out, twmr.simulate(tmp_path / "closed.yaml", out, compiled="off")


def open_loop(tmp_path: Path, data: str) -> Path:
    """The paper's plant, motor and slip with the controller's torque from a data block."""
    path = tmp_path / "open.yaml"
    path.write_text(f"""components:
  tq:
    kind: data
    parameters: {{{data}}}
  motor: {{kind: motor_driver, parameters: {{mode: ideal, torque_max: 48.0}}}}
  plant:
    kind: twmr_plant
    parameters: {{scale: 1.25}}
    initial: {{pose: [0.5, 0.0, -0.7853981633974483]}}
  slip: {{kind: slip_disturbance, parameters: {{profile: paper}}}}
connections:
  - tq.y -> motor.torque_command
  - plant.wheel_speed -> motor.wheel_speed
  - motor.torque -> plant.torque
  - slip.slip_rate -> plant.slip_rate
  - slip.slip_accel -> plant.slip_accel
  - slip.disturbance -> plant.disturbance
  - plant.pose -> slip.pose
  - slip.model -> plant.slip_model
experiment: {{start: 0.0, stop: {STOP}, step: 1.0e-3, algorithm: gauss_seidel}}
record: {{signals: [tq.y, plant.pose, plant.wheel_speed, motor.torque]}}
""")
    return path


@pytest.mark.parametrize("compiled", ["off", "on"])
def test_a_recorded_runs_torques_give_its_rows_bit_for_bit(tmp_path: Path, compiled: str
                                                           ) -> None:
    folder, closed = recorded(tmp_path, 1)
    scenario = open_loop(tmp_path, f"file: {folder.name}, columns: ['ctrl.torque[1]', "
                                   f"'ctrl.torque[2]']")
    played = twmr.simulate(scenario, tmp_path / "open", compiled=compiled)
    assert played.units["tq.y[1]"] == "N.m"
    assert len(played["time"]) == len(closed["time"]) == round(STOP / 1e-3) + 1
    np.testing.assert_array_equal(played["tq.y[1]"], closed["ctrl.torque[1]"])
    for name in ("plant.pose[1]", "plant.pose[2]", "plant.pose[3]", "plant.wheel_speed[2]",
                 "motor.torque[1]"):
        np.testing.assert_array_equal(played[name], closed[name], err_msg=name)


def test_samples_between_steps_are_interpolated(tmp_path: Path) -> None:
    """Torques recorded every 10 ms, played at 1 ms: linear as np.interp; held as the last
    sample at or before each time; shifted by time_offset and scaled."""
    folder, closed = recorded(tmp_path, 10)
    t_rec, tau = closed["time"], closed["ctrl.torque[1]"]
    runs = {}
    for name, extra in (("linear", ""), ("hold", ", interpolation: hold"),
                        ("shifted", ", time_offset: 0.0125, scale: -2.0")):
        scenario = open_loop(tmp_path, f"file: {folder.name}/result.arrows, columns: "
                                       f"['ctrl.torque[1]', 'ctrl.torque[2]']{extra}")
        runs[name] = twmr.simulate(scenario, tmp_path / name)["tq.y[1]"]
    t = np.arange(round(STOP / 1e-3) + 1) * 1e-3
    np.testing.assert_allclose(runs["linear"], np.interp(t, t_rec, tau), rtol=0, atol=1e-12)
    held = tau[np.searchsorted(t_rec, t + 1e-12, side="right") - 1]
    np.testing.assert_array_equal(runs["hold"], held)
    np.testing.assert_allclose(runs["shifted"], -2.0 * np.interp(t - 0.0125, t_rec, tau),
                               rtol=0, atol=1e-12)
    assert not np.allclose(runs["linear"], runs["hold"])  # the two differ between samples


def write_csv(path: Path, rows: str) -> None:
    path.write_text("time [s],x [m],y [m],a [rad]\n" + rows)


GOOD = "0.0,0.0,1.0,0.1\n0.5,1.0,2.0,0.2\n1.0,2.0,3.0,0.3\n"


def test_a_csv_with_units_in_its_header_plays(tmp_path: Path) -> None:
    write_csv(tmp_path / "m.csv", GOOD)
    scenario = twmr.load(f"""components:
  d: {{kind: data, parameters: {{file: {tmp_path / 'm.csv'}, columns: [y, x]}}}}
experiment: {{stop: 1.25, step: 0.25}}
record: {{signals: [d.y]}}
""")
    result = twmr.simulate(scenario, tmp_path / "out")
    assert result.units["d.y[1]"] == "m"
    np.testing.assert_array_equal(result["d.y[1]"], [1.0, 1.5, 2.0, 2.5, 3.0, 3.0])
    np.testing.assert_array_equal(result["d.y[2]"], [0.0, 0.5, 1.0, 1.5, 2.0, 2.0])


@pytest.mark.parametrize("rows, columns, said, above", [
    (GOOD, "[x, z]", r"m\.csv: no column 'z'", ""),
    (GOOD, "[x, a]", r"different units \(x \[m\], a \[rad\]\)", ""),
    ("0.0,0,1,0\n0.5,1,2,0\n0.4,2,3,0\n", "[x]", r"goes back from 0\.5 to 0\.4 at line 4", ""),
    ("0.0,0,1,0\n0.5,,2,0\n1.0,2,3,0\n", "[x, y]",
     r"column 'x' has no number \(empty, or text\) at line 3", ""),
    ("0.0,0,1,0\n0.5,,2,0\n1.0,2,3,0\n", "[x, y]",  # below a logger's two '#' lines
     r"column 'x' has no number \(empty, or text\) at line 5", "# logger 2.1\n# 10 Hz\n"),
])
def test_what_cannot_be_played_is_refused_naming_file_column_and_row(
        tmp_path: Path, rows: str, columns: str, said: str, above: str) -> None:
    write_csv(tmp_path / "m.csv", rows)
    (tmp_path / "m.csv").write_text(above + (tmp_path / "m.csv").read_text())
    path = tmp_path / "s.yaml"
    path.write_text(f"""components:
  d: {{kind: data, parameters: {{file: m.csv, columns: {columns}}}}}
experiment: {{stop: 1.0, step: 0.25}}
""")
    with pytest.raises(CosimError, match=said) as err:
        twmr.load(path)
    assert "s.yaml:2" in str(err.value) and "Traceback" not in str(err.value)
