"""Each paper scenario exported as SSP 1.0 with FMI 2.0 C FMUs (`twmr.fmi.ssp.write`) runs in
two co-simulation engines we did not write — Ecos (ecospy) and libcosim (libcosimpy), both from
PyPI — and is read by a third (fmpy.ssp); the engines' results equal our master's run of the same
scenario under the same algorithm (fixed-step Jacobi, the scenario's 1 ms step, 2 s) within
1e-9 of each signal's scale, max(1, max |ours|). Measured: at most 7.3e-12 (docs/systems.md,
SSP export).

What each tool samples, and how the comparison lines them up (t_n = n h):

- Jacobi, all three: every block steps from t_n with its inputs held; then each input gets its
  source's output as the FMU reports it after the step (a feedthrough output evaluated at
  t_n+1 with the inputs still held). Our master's native blocks leave their outputs in that state
  after `do_step`, and its Jacobi snapshot passes them on.
- Initial values: Ecos and libcosim iterate initialization mode, each input getting its
  source's output as the FMU computes it there from the inputs set so far; our master, after
  initializing every block, passes the outputs on and evaluates the feedthrough blocks as often
  (`twmr.master.jacobi_start`). Each is run from the scenario as written.
- Ecos: read after initialization and after each step, when the new inputs are set and the
  outputs read again: the values our master records at t_0 .. t_N (feedthrough outputs with the
  new inputs). Every recorded column is compared, rows t_0 .. t_N.
- libcosim: its observer reads each FMU right after its step, before the inputs are set:
  states and outputs without feedthrough are ours at t_n+1; an input shows the value it held
  during the step, ours at t_n; a feedthrough output shows its value before the new inputs
  (what its wired inputs receive, compared there), so feedthrough columns are left out.

Skipped only when an engine cannot be loaded here (ecospy's library needs the system's oneTBB:
`apt-get install libtbb12`)."""
from __future__ import annotations

import zipfile

import numpy as np
import pytest
import yaml

from tests.integration import ssp_runners as r
from twmr.fmi.ssp.write import export_ssp

BOUND = 1e-9


def _engine(name: str) -> None:
    try:
        __import__(name)
    except OSError as err:  # a shared library the package loads at import
        pytest.skip(f"{name} is installed but its library cannot be loaded here ({err}); "
                    f"ecospy needs oneTBB: apt-get install libtbb12")
    except ImportError:
        pytest.skip(f"{name} is not installed: pip install -e '.[test]'")


@pytest.fixture(scope="module", params=r.PAPER, ids=lambda p: p.stem)
def exported(request, tmp_path_factory):
    """(scenario data, its SSP, our rows of it)."""
    data = r.short(request.param)
    folder = tmp_path_factory.mktemp(request.param.stem)
    scenario = folder / f"{request.param.stem}.yaml"
    scenario.write_text(yaml.safe_dump(data, sort_keys=False))
    ssp = export_ssp(scenario, folder / f"{request.param.stem}.ssp")
    return data, ssp, r.ours(data)


def _columns(rows: np.ndarray) -> list[str]:
    return [c for c in rows.dtype.names if c != "time"]


def test_ecos_runs_the_ssp_as_we_do(exported) -> None:
    _engine("ecospy")
    data, ssp, ours = exported
    cols = _columns(ours)
    step, n = data["experiment"]["step"], len(ours) - 1
    with zipfile.ZipFile(ssp) as z:  # every block's .ssv holds one parameter set of one name
        name = _set_name(z)
    rows = r.ecos(ssp, cols, step, n, name)
    errors = {c: r.worst(rows[:, j], ours[c], ours[c]) for j, c in enumerate(cols)}
    assert len(cols) > 50 and n == 2000
    assert max(errors.values()) <= BOUND, sorted(errors.items(), key=lambda e: -e[1])[:5]


def test_libcosim_runs_the_ssp_as_we_do(exported) -> None:
    _engine("libcosimpy")
    data, ssp, ours = exported
    cols = _columns(ours)
    step, n = data["experiment"]["step"], len(ours) - 1
    kinds = r.kinds(r.system(data), cols)
    rows = r.libcosim(ssp, cols, step, n)
    errors = {}
    for j, c in enumerate(cols):
        if kinds[c] == "feedthrough":
            continue
        mine = ours[c][:-1] if kinds[c] == "input" else ours[c][1:]
        errors[c] = r.worst(rows[:, j], mine, ours[c])
    assert sum(k == "input" for k in kinds.values()) > 20
    assert any(c.startswith("plant.pose") for c in errors)
    assert max(errors.values()) <= BOUND, sorted(errors.items(), key=lambda e: -e[1])[:5]


def test_fmpy_reads_the_ssp(exported) -> None:
    from fmpy.ssp.ssd import find_components, get_connections, read_ssd

    data, ssp, _ = exported
    ssd = read_ssd(str(ssp), validate=True)  # fmpy's copy of the standard's schema
    comps = {c.name: c for c in find_components(ssd.system)}
    assert set(comps) == set(data["components"])
    plant = comps["plant"]
    values = {p.name: float(p.value) for b in plant.parameterBindings
              for s in b.parameterValues for p in s.parameters}
    given = data["components"]["plant"]
    assert values["scale"] == given["parameters"]["scale"]
    assert [values[f"pose[{i}]"] for i in (1, 2, 3)] == given["initial"]["pose"]
    built = r.system(data)
    elements = 0
    for c in built.connections:
        value = built.components[c.dst].get(c.dst_port)
        elements += len(c.dst_index) if c.dst_index is not None else \
            len(value) if isinstance(value, tuple) else 1
    wires = get_connections(ssd.system)
    assert len(wires) == elements > len(data["connections"])
    for start, end in wires:
        assert start.kind == "output" and end.kind == "input"


def _set_name(z: zipfile.ZipFile) -> str:
    from lxml import etree

    names = {etree.fromstring(z.read(n)).get("name") for n in z.namelist()
             if n.endswith(".ssv")}
    assert len(names) == 1
    return names.pop()


@pytest.mark.parametrize("compiled", ["off", "on"])
def test_our_master_runs_the_ssps_fmus_as_the_native_blocks(compiled, tmp_path, monkeypatch):
    """The SSP's blocks are the C FMUs: in our master under Jacobi (Python and compiled loops;
    the controller isolated in a worker process) they give the native blocks' rows. (The FMU
    block gets its feedthrough outputs after doStep under Jacobi, as the engines above do.)"""
    from tests.integration.c_fmu_scenario import export_blocks, swapped

    monkeypatch.setenv("TWMR_COMPILED", compiled)
    data = r.short(r.ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", stop=1.0)
    fmu_data = swapped(data, export_blocks(data, tmp_path))
    if compiled == "off":
        fmu_data["components"]["ctrl"]["parameters"]["isolate"] = True
    native, fmus = r.ours(data), r.ours(fmu_data)
    assert len(native) == 1001
    for c in _columns(native):
        assert r.worst(fmus[c], native[c], native[c]) <= 1e-12, c
