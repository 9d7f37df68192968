"""Every standalone C FMU (each exportable kind, FMI 2.0 and 3.0) through importers we did not
write: fmpy's validation and simulate_fmu, and a small C host (tests/hosts/fmi_host.c) that loads
the binary with dlopen, runs two instances side by side 100 times, and agrees with fmpy to the
last bit; under valgrind with no memory error. The ports an importer sees (twmr inspect, through
fmpy) are the native component's: names, kinds, sizes, units, start values, feedthrough."""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from twmr.fmi import fmu_interface
from twmr.fmi.cexport import C_DIR, export_c_fmu, twin_of, twins
from twmr.registry import lookup

HOST = Path(__file__).resolve().parents[1] / "hosts" / "fmi_host.c"
CASES = [(k, f) for k in sorted(twins()) for f in (2, 3)]
STEPS = 100


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[tuple[str, int], Path]:
    out = tmp_path_factory.mktemp("c_fmus")
    return {(k, f): export_c_fmu(k, out / f"{k}_{f}.fmu", fmi=f) for k, f in CASES}


@pytest.fixture(scope="module")
def hosts(tmp_path_factory) -> dict[int, Path]:
    out = tmp_path_factory.mktemp("hosts")
    built = {}
    for fmi in (2, 3):
        exe = out / f"host{fmi}"
        subprocess.run(["cc", "-O1", "-Wall", "-Werror", *(["-DFMI3"] if fmi == 3 else []),
                        f"-I{C_DIR}", str(HOST), "-o", str(exe), "-ldl", "-lm"], check=True)
        built[fmi] = exe
    return built


def _ids(case: tuple[str, int]) -> str:
    return f"{case[0]}-fmi{case[1]}"


@pytest.mark.parametrize("case", CASES, ids=_ids)
def test_fmpy_validates_and_simulates(case, fmus) -> None:
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    kind, fmi = case
    path = fmus[case]
    assert validate_fmu(str(path)) == []
    names = zipfile.ZipFile(path).namelist()
    folder = "binaries/linux64/" if fmi == 2 else "binaries/x86_64-linux/"
    assert any(n.startswith(folder) and n.endswith(".so") for n in names), names
    assert {"sources/config.h", "sources/kernel.h", f"sources/fmi{fmi}.c",
            f"sources/{twin_of(kind).source.name}"} <= set(names)
    assert ("sources/buildDescription.xml" in names) == (fmi == 3)
    result = simulate_fmu(str(path), stop_time=0.5, step_size=1e-3, output_interval=0.01)
    assert len(result) == 51
    for col in result.dtype.names:
        assert np.all(np.isfinite(result[col])), col


@pytest.mark.parametrize("case", CASES, ids=_ids)
def test_ports_seen_by_an_importer_are_the_components(case, fmus) -> None:
    kind, _fmi = case
    comp = lookup(kind)(kind)
    twin_of(kind).fill_empty(comp)  # state_space x0 = (): n zeros
    ports = {p["name"]: p for p in fmu_interface(fmus[case])["ports"]}
    hidden = twin_of(kind).hidden
    for var in comp.variables.values():
        value = comp.get(var.name)
        if var.type != "Real" or var.name in hidden or (var.size == 0 and not value):
            assert var.name not in ports  # an empty list (gain's K) has no element
            continue
        p = ports.pop(var.name)
        start = list(value) if isinstance(value, tuple) else value
        if var.size == 0 and len(start) == 1:  # importers read a one-element array as a scalar
            start = start[0]
        assert p["kind"] == var.kind, var.name
        assert p["size"] == (None if var.size == 0 and not isinstance(start, list) else
                             len(start) if var.size == 0 else var.size), var.name
        unit = list(var.unit) if isinstance(var.unit, tuple) else var.unit
        assert p["unit"] == unit, var.name
        if var.kind == "output":
            assert sorted(p["depends_on"]) == sorted(var.depends_on), var.name
        else:
            assert p["start"] == start, var.name
    assert not ports  # FMI 3.0's independent variable `time` is not a port

def _first(md: str, causality: tuple[str, ...]) -> int:
    """Value reference of the first variable of one of these causalities (-1: none)."""
    for attrs in re.findall(r"<(?:ScalarVariable|Float64) ([^>]*)>", md):
        if re.search(r'causality="({})"'.format("|".join(causality)), attrs):
            return int(re.search(r'valueReference="(\d+)"', attrs).group(1))
    return -1


def _fmpy_run(path: Path, fmi: int, vr_in: int, value: float, vr_out: int) -> float:
    """What fmpy computes for the host's run: input `value` at every step, STEPS steps of 1 ms."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(path))
    folder = extract(str(path))
    try:
        cls = FMU2Slave if fmi == 2 else FMU3Slave
        fmu = cls(guid=md.guid, unzipDirectory=folder,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
        fmu.instantiate()
        if fmi == 2:
            fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for k in range(STEPS):
            if vr_in >= 0:
                (fmu.setReal if fmi == 2 else fmu.setFloat64)([vr_in], [value])
            fmu.doStep(k * 1e-3, 1e-3)
        y = (fmu.getReal if fmi == 2 else fmu.getFloat64)([vr_out])[0]
        fmu.terminate()
        fmu.freeInstance()
        return y
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _host_args(path: Path, fmi: int, tmp: Path) -> tuple[list[str], int, int]:
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp)
        md = z.read("modelDescription.xml").decode()
    guid = re.search(r'(?:guid|instantiationToken)="([^"]+)"', md).group(1)
    binary = next((tmp / "binaries").rglob("*.so"))
    vr_in, vr_out = _first(md, ("input",)), _first(md, ("output",))
    return [str(binary), guid], vr_in, vr_out


@pytest.mark.parametrize("case", CASES, ids=_ids)
def test_c_host_runs_two_instances_100_times_and_agrees_with_fmpy(case, fmus, hosts,
                                                                  tmp_path) -> None:
    _kind, fmi = case
    args, vr_in, vr_out = _host_args(fmus[case], fmi, tmp_path)
    done = subprocess.run([str(hosts[fmi]), *args, "100", str(STEPS), str(vr_in), str(vr_out)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    y1, y2 = (float(x) for x in done.stdout.split()[1:])
    assert y1 == _fmpy_run(fmus[case], fmi, vr_in, 1.0, vr_out)
    assert y2 == _fmpy_run(fmus[case], fmi, vr_in, 2.0, vr_out)


VALGRIND = shutil.which("valgrind")


@pytest.mark.skipif(VALGRIND is None, reason="valgrind is not installed")
@pytest.mark.parametrize("case", [("twmr_plant", 2), ("twmr_plant", 3), ("asmc", 2),
                                  ("asmc", 3), ("state_space", 2), ("motor_driver", 3)],
                         ids=_ids)
def test_c_host_under_valgrind_has_no_memory_error(case, fmus, hosts, tmp_path) -> None:
    _kind, fmi = case
    args, vr_in, vr_out = _host_args(fmus[case], fmi, tmp_path)
    done = subprocess.run([VALGRIND, "--leak-check=full", "--errors-for-leak-kinds=definite",
                           str(hosts[fmi]), *args, "3", "50", str(vr_in), str(vr_out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "ERROR SUMMARY: 0 errors" in done.stderr, done.stderr[-2000:]
    assert "definitely lost: 0 bytes" in done.stderr or "no leaks are possible" in done.stderr
