"""The instances of one FMU file share one unpacked folder (and so its library, loaded once) and
one model description; an FMU that can be instantiated only once per process gets a folder, a
library, of each instance's own; the folder goes when its last instance terminates; a file that
changes is read and unpacked anew. Run on the Modelica Association's Reference FMUs."""
from __future__ import annotations

import itertools
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.fmi import unpacked
from twmr.fmi.description import read_description

pytestmark = pytest.mark.timeout(120)


def chain(path: Path, n: int) -> str:
    names = [f"f{i}" for i in range(n)]
    wires = ", ".join(f"{a}.Float64_continuous_output -> {b}.Float64_continuous_input"
                      for a, b in itertools.pairwise(names))
    comps = "\n".join(f"  {x}: {{kind: fmu, parameters: {{path: '{path}'}}}}" for x in names)
    return (f"components:\n{comps}\nconnections: [{wires}]\nopen: ['f*']\n"
            f"experiment: {{stop: 0.003, step: 0.001}}\n"
            f"record: {{signals: [{names[-1]}.Float64_continuous_output]}}\n")


def folders(system: object) -> list[str]:
    return [c._unzipped for c in system.components.values()]  # type: ignore[attr-defined]


def test_instances_of_one_file_share_its_folder_until_the_last_ends(tmp_path: Path) -> None:
    fmu = shutil.copy(corpus("reference-fmus", "Feedthrough_fmi2.fmu"), tmp_path / "ft.fmu")
    scenario = twmr.load(chain(Path(fmu), 5))
    system = scenario.fresh_system()
    for comp in system.components.values():
        comp.setup(0.0, 0.003)
    taken = folders(system)
    assert len(set(taken)) == 1 and Path(taken[0]).is_dir()
    comps = list(system.components.values())
    for comp in comps[:-1]:
        comp.terminate()
    assert Path(taken[0]).is_dir()  # one instance still holds it
    comps[-1].terminate()
    assert not Path(taken[0]).exists()
    # and a run through them computes what one instance would
    result = twmr.simulate(scenario)
    assert np.all(np.isfinite(result["f4.Float64_continuous_output"]))


def test_an_fmu_instantiated_once_per_process_gets_copies(tmp_path: Path) -> None:
    source = corpus("reference-fmus", "Feedthrough_fmi2.fmu")
    once = tmp_path / "once.fmu"
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(once, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b"<CoSimulation", b"<CoSimulation\n    "
                                    b"canBeInstantiatedOnlyOncePerProcess=\"true\"", 1)
            zout.writestr(item, data)
    system = twmr.load(chain(once, 3)).fresh_system()
    try:
        for comp in system.components.values():
            comp.setup(0.0, 0.003)
        assert len(set(folders(system))) == 3
    finally:
        for comp in system.components.values():
            comp.terminate()


def test_a_changed_file_is_read_and_unpacked_anew(tmp_path: Path) -> None:
    path = Path(shutil.copy(corpus("reference-fmus", "Feedthrough_fmi2.fmu"), tmp_path / "x.fmu"))
    first = read_description(path)
    folder = unpacked.take(path, shared=True)
    shutil.copy(corpus("reference-fmus", "Dahlquist_fmi2.fmu"), path)  # another FMU, same name
    second = read_description(path)
    assert (first.modelName, second.modelName) == ("Feedthrough", "Dahlquist")
    other = unpacked.take(path, shared=True)
    assert other != folder
    assert (Path(other) / "modelDescription.xml").read_bytes().count(b"Dahlquist")
    unpacked.give_back(folder)
    unpacked.give_back(other)
    assert not Path(folder).exists() and not Path(other).exists()
