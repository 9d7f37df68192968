"""Export (Python route): every native kind becomes an FMI 2.0 CS FMU that passes fmpy's
validation, with units and feedthrough in its model description and our binary instead of
pythonfmu's; one runs on its own in fmpy.simulate_fmu; bad export targets and a missing compiler
are refused clearly; an FMU without a binary for this platform is refused clearly."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from twmr.core import CosimError, FmuError
from twmr.fmi import export_component
from twmr.fmi.export import wrapper_binary
from twmr.fmi.fmu import FmuComponent
from twmr.registry import kinds

NATIVE = sorted(k for k in kinds() if k not in ("fmu", "can_drive"))


@pytest.mark.parametrize("kind", NATIVE)
def test_every_native_kind_exports_a_valid_fmu(kind, tmp_path) -> None:
    fmu = export_component(kind, tmp_path / f"{kind}.fmu")
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.fmiVersion == "2.0" and md.coSimulation is not None


def test_units_and_feedthrough_in_the_model_description(tmp_path) -> None:
    md = read_model_description(str(export_component("asmc", tmp_path / "asmc.fmu")))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["torque[1]"].unit == "N.m" and by_name["pose[3]"].unit == "rad"
    assert {u.name for u in md.unitDefinitions} >= {"N.m", "rad/s", "m"}
    torque = next(o for o in md.outputs if o.variable.name == "torque[1]")
    assert {d.name for d in torque.dependencies} >= {"pose[1]", "wheel_speed[2]"}
    d_hat = next(o for o in md.outputs if o.variable.name == "d_hat[1]")
    assert d_hat.dependencies == []


def test_exported_plant_runs_alone_in_fmpy(tmp_path) -> None:
    """In a fresh interpreter (the slave runs inside it): a constant torque from rest."""
    fmu = export_component("twmr_plant", tmp_path / "plant.fmu")
    code = (f"from fmpy import simulate_fmu\n"
            f"r = simulate_fmu({str(fmu)!r}, stop_time=1.0, output_interval=0.01, "
            f"start_values={{'torque[1]': 1.0, 'torque[2]': 1.0}})\n"
            f"print(r['wheel_speed[1]'][-1], r['pose[1]'][-1])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout.split()
    w, x = float(out[0]), float(out[1])
    # straight line: M nu' = tau with equal torques -> nu' = tau / (m11 + m12)
    from twmr.components.plant import TwmrPlant

    p = TwmrPlant("p")
    p.setup(0, 1)
    p.initialize()
    accel = 1.0 / (p.m11 + p.m12)
    assert w == pytest.approx(accel * 1.0, rel=1e-9)
    assert x == pytest.approx(0.15 * accel / 2.0, rel=1e-9)  # x = r * accel * t^2 / 2


def test_fmu_without_a_binary_for_this_platform(tmp_path) -> None:
    src = export_component("gain", tmp_path / "gain.fmu")
    stripped = tmp_path / "nobinary.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(stripped, "w") as zout:
        for item in zin.namelist():
            if not item.startswith("binaries/linux64"):
                zout.writestr(item, zin.read(item))
    with pytest.raises(FmuError, match=r"no binary for this platform.*no C sources"):
        FmuComponent("g", stripped)  # refused when loaded, so at `twmr check`


def test_the_fmu_carries_our_binary_not_pythonfmus(tmp_path) -> None:
    import fmpy

    fmu = export_component("motor_driver", tmp_path / "m.fmu")
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        assert z.read("resources/slaveclass.txt") == b"MotorDriver"
    binaries = {n for n in names if n.startswith("binaries/")}
    assert binaries == {f"binaries/{fmpy.platform}/MotorDriver{fmpy.sharedLibraryExtension}"}
    assert not any(n.startswith("resources/pythonfmu/") for n in names)
    assert read_model_description(str(fmu)).generationTool.startswith("twmr-cosim ")


@pytest.mark.parametrize("target, message", [
    ("no_such_module_xyz:Thing", "cannot load the class .no module .no_such_module_xyz."),
    ("twmr.blocks:NoSuchClass", "cannot load the class ..twmr.blocks. has no .NoSuchClass."),
    ("missing_file.py:Thing", "cannot load the class .there is no file .*missing_file.py"),
    ("pathlib:Path", "is not a twmr Component class"),
    ("no_such_kind", "no_such_kind.*`twmr components` lists the kinds"),
])
def test_bad_export_targets_are_refused_clearly(target, message, tmp_path) -> None:
    with pytest.raises(CosimError, match=message):
        export_component(target, tmp_path / "x.fmu")
    assert not (tmp_path / "x.fmu").exists()


def test_a_class_object_exports_like_its_kind(tmp_path) -> None:
    from twmr.blocks import Gain

    md = read_model_description(str(export_component(Gain, tmp_path / "g.fmu", {"k": 2.0})))
    assert md.coSimulation.modelIdentifier == "Gain"
    assert {v.name for v in md.modelVariables} == {"k", "n_in", "n_out", "u", "y"}


def test_no_c_compiler_is_a_clear_error(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("CC", "/nonexistent/cc")
    wrapper_binary.cache_clear()
    try:
        with pytest.raises(CosimError, match=r"needs a C compiler.*/nonexistent/cc.*Fix"):
            export_component("gain", tmp_path / "g.fmu")
    finally:
        wrapper_binary.cache_clear()
