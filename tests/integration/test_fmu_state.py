"""FMU states through fmpy, in the process and isolated (`isolate: true`), with real FMUs built from
tests/fmus: `can_get_and_set_state` follows the model description (FMI 2.0 and 3.0, co-simulation
and model exchange); a restored state continues exactly as the first continuation did (model
exchange with CVODE too); states are freed, so 10,000 save/restore cycles keep the memory of the
process and of the isolation worker flat; a state is plain values that pickle (serialised bytes
where the FMU can serialise)."""
from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path

import pytest

from tests.fmu_build import build_c_fmu
from twmr.core.errors import FmuError
from twmr.fmi.fmu import FmuComponent
from twmr.fmi.isolated import IsolatedFmu
from twmr.fmi.states import KEEP

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="isolation is POSIX only")

#: "flat": the growth allowed between the 1,000th and the 10,000th cycle [bytes]; one state of
#: the faulty FMU is 16 KiB, so keeping or leaking the 9,000 cycles between would be 140 MiB
TOLERANCE = 4 * 2**20


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("fmus")
    built = {name: build_c_fmu(name, folder) for name in ("faulty", "lag2")}
    built.update({name: build_c_fmu(name, folder, fmi3=True) for name in ("lag3", "types3")})
    return built


def make(cls: type, fmu: Path, **kwargs) -> FmuComponent | IsolatedFmu:
    comp = cls("dut", fmu, **kwargs)
    comp.setup(0.0, None)
    comp.initialize()
    return comp


def drive(comp, t0: float, n: int, h: float = 0.01) -> list[tuple]:
    """n steps from t0 with every input at sin(3 t): the outputs after each."""
    rows = []
    for k in range(n):
        t = t0 + k * h
        for name, var in comp.inputs.items():
            value = math.sin(3.0 * t)
            setattr(comp, name, value if var.size is None else (value,) * var.size)
        comp.do_step(t, h)
        rows.append(tuple(comp.get(name) for name in comp.outputs))
    return rows


CASES = {"faulty (FMI 2, serialised)": ("faulty", {}),
         "lag2 (FMI 2, held by the FMU)": ("lag2", {}),
         "lag3 (FMI 3, serialised)": ("lag3", {}),
         "lag2 model exchange, rk4": ("lag2", {"interface": "model_exchange", "solver": "rk4",
                                               "solver_step": 0.002})}


@pytest.mark.parametrize("cls", [FmuComponent, IsolatedFmu])
@pytest.mark.parametrize("case", list(CASES))
def test_a_restored_state_continues_as_the_first_continuation(fmus, cls, case) -> None:
    name, kwargs = CASES[case]
    comp = make(cls, fmus[name], **kwargs)
    try:
        assert comp.can_get_and_set_state
        drive(comp, 0.0, 20)
        saved = comp.get_state()
        assert pickle.loads(pickle.dumps(saved)) == saved
        first = drive(comp, 0.2, 30)
        comp.set_state(saved)
        again = drive(comp, 0.2, 30)
        assert again == first  # bit for bit
        assert first[0] != first[-1]
    finally:
        comp.terminate()


def test_model_exchange_with_cvode_continues_bit_for_bit(fmus) -> None:
    """CVODE restarts at a save as at a restore, so both continuations start alike."""
    comp = make(FmuComponent, fmus["lag2"], interface="model_exchange", rtol=1e-9)
    try:
        drive(comp, 0.0, 20)
        saved = comp.get_state()
        first = drive(comp, 0.2, 30)
        comp.set_state(saved)
        assert drive(comp, 0.2, 30) == first
    finally:
        comp.terminate()


def test_a_serialised_state_restores_into_another_instance(fmus) -> None:
    a, b = make(FmuComponent, fmus["lag3"]), make(FmuComponent, fmus["lag3"])
    try:
        drive(a, 0.0, 15)
        saved = pickle.loads(pickle.dumps(a.get_state()))
        assert isinstance(saved[0], bytes)
        first = drive(a, 0.15, 10)
        b.set_state(saved)
        assert drive(b, 0.15, 10) == first
    finally:
        a.terminate()
        b.terminate()


def test_an_fmu_that_does_not_declare_state_support_refuses_clearly(fmus) -> None:
    for cls in (FmuComponent, IsolatedFmu):
        comp = make(cls, fmus["types3"])
        try:
            assert not comp.can_get_and_set_state
            with pytest.raises(FmuError) as err:
                comp.get_state()
            message = str(err.value)
            assert message.startswith("component 'dut': FMU 'types3.fmu' cannot save its state")
            assert 'canGetAndSetFMUState="true" for co-simulation' in message
            assert "Fix:" in message
        finally:
            comp.terminate()


def test_states_held_by_the_fmu_are_bounded_and_freed_on_release(fmus) -> None:
    comp = make(FmuComponent, fmus["lag2"])
    try:
        states = [comp.get_state() for _ in range(KEEP + 10)]
        assert all(isinstance(s[0], int) for s in states)
        assert len(comp._states) == KEEP
        with pytest.raises(FmuError, match=r"state 1 was released .* at most the last 64"):
            comp.set_state(states[0])
        comp.set_state(states[-1])
        for s in states[-5:]:
            comp.release_state(s)
        assert len(comp._states) == KEEP - 5
    finally:
        comp.terminate()


def rss(pid: int | str = "self") -> int:
    """Resident set size of process `pid` [bytes]."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS")


def worker_of(fmu: Path) -> int:
    """The pid of the one isolation worker serving `fmu`."""
    found = [int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit() and
             _cmdline(p).count(b"twmr.fmi.worker") and str(fmu).encode() in _cmdline(p)]
    assert len(found) == 1, found
    return found[0]


def _cmdline(proc: Path) -> bytes:
    try:
        return (proc / "cmdline").read_bytes()
    except OSError:
        return b""


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc")
@pytest.mark.parametrize("cls", [FmuComponent, IsolatedFmu])
def test_ten_thousand_save_restore_cycles_keep_memory_flat(fmus, cls) -> None:
    comp = make(cls, fmus["faulty"])
    pid = worker_of(fmus["faulty"]) if cls is IsolatedFmu else "self"
    sizes = {}
    try:
        for cycle in range(1, 10_001):
            saved = comp.get_state()
            if cycle % 10 == 0:
                comp.do_step(0.0, 0.01)
            comp.set_state(saved)
            if cycle in (1_000, 10_000):
                sizes[cycle] = rss(pid)
        assert comp.get("y") == 0.0  # every step was rolled back
    finally:
        comp.terminate()
    growth = sizes[10_000] - sizes[1_000]
    assert growth < TOLERANCE, f"RSS of {pid} grew {growth / 2**20:.1f} MiB over 9,000 cycles"
