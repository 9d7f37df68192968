"""The Python export route (pythonfmu's slave API, our FMI binary) under real importers: fmpy in
fresh processes (a crash there cannot take pytest down, and shows as a non-zero exit code), a C
host that is not Python, and a Python host that cannot import twmr.

pythonfmu 0.7.0's own binary crashed these runs (double two instances: SIGSEGV every time;
simulate_fmu of asmc/smc: SIGSEGV or abort at exit in about half the runs) by releasing, on every
fmi2Instantiate, a reference to the slave module's dict that it did not own.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from twmr.fmi import export_component

RUNS = 20  # simulate_fmu runs per exported block, each in its own process

#: two instances of one FMU in one process, stepped interleaved with opposite torques
TWO_INSTANCES = """
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
unzipped = extract(sys.argv[1])
vr = {v.name: v.valueReference for v in md.modelVariables}
fmus = []
for name in ("a", "b"):
    f = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    fmus.append(f)
for f, tau in zip(fmus, (1.0, -1.0)):
    f.setReal([vr["torque[1]"], vr["torque[2]"]], [tau, tau])
for k in range(100):
    for f in fmus:
        f.doStep(k * 0.01, 0.01)
print(*[f.getReal([vr["wheel_speed[1]"]])[0] for f in fmus])
for f in fmus:
    f.terminate()
    f.freeInstance()
"""

#: 100 instantiate/step/terminate/free cycles in one process (fmpy also reloads the library)
CYCLES = """
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
unzipped = extract(sys.argv[1])
for i in range(100):
    f = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"i{i}")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    for k in range(5):
        f.doStep(k * 0.01, 0.01)
    f.terminate()
    f.freeInstance()
print("cycles", i + 1)
"""

#: simulate_fmu three times in one process (pythonfmu's binary failed the second fmi2Instantiate)
AGAIN = """
import sys
from fmpy import simulate_fmu
runs = [simulate_fmu(sys.argv[1], stop_time=0.5, output_interval=0.01) for _ in range(3)]
print(all((r == runs[0]).all() for r in runs), len(runs[0]))
"""

SIMULATE = """
import sys
from fmpy import simulate_fmu
r = simulate_fmu(sys.argv[1], stop_time=0.5, output_interval=0.01)
print(len(r))
"""

#: fmpy's simulate_fmu with a logger that prints what the FMU logs
LOGGED = """
import sys
from fmpy import simulate_fmu
def logger(env, name, status, category, message):
    print("LOG", message.decode())
try:
    simulate_fmu(sys.argv[1], stop_time=0.1, logger=logger)
except Exception as exc:
    print("FAILED", exc)
"""

#: a host that is not Python: loads the binary, instantiates, expects a refusal in its log
C_HOST = r"""
#include <dlfcn.h>
#include <stdio.h>
#include "fmi2Functions.h"
static void logger(fmi2ComponentEnvironment e, fmi2String name, fmi2Status s, fmi2String c,
                   fmi2String message, ...) { printf("LOG %s\n", message); }
int main(int argc, char** argv) {
    void* lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { printf("DLOPEN %s\n", dlerror()); return 1; }
    fmi2InstantiateTYPE* instantiate = (fmi2InstantiateTYPE*)dlsym(lib, "fmi2Instantiate");
    fmi2CallbackFunctions cb = {logger, NULL, NULL, NULL, NULL};
    fmi2Component c = instantiate("x", fmi2CoSimulation, "", argv[2], &cb, 0, 0);
    printf(c ? "INSTANCE\n" : "NULL\n");
    dlclose(lib);
    return c ? 2 : 0;
}
"""

#: a component class of the user's, in a file of its own
USER_MODULE = '''
from twmr.core.component import Component
from twmr.core.port import Input, Output, Parameter


class Leaky(Component):
    """y' = -a y + u, one explicit Euler step per communication step."""

    a = Parameter(0.5)
    u = Input(0.0)
    y = Output(0.0)

    def do_step(self, t, h):
        self.y += h * (-self.a * self.y + self.u)
'''


def run(code: str, *args: str, cwd: Path | None = None,
        env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *(["-S"] if env else []), "-c", code, *args],
                          capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("pyexport")
    return {k: export_component(k, out / f"{k}.fmu") for k in ("twmr_plant", "asmc", "smc")}


def test_two_instances_of_one_fmu_in_one_process(fmus) -> None:
    done = run(TWO_INSTANCES, str(fmus["twmr_plant"]))
    assert done.returncode == 0, done.stderr[-2000:]
    a, b = map(float, done.stdout.split())
    from twmr.components.plant import TwmrPlant

    p = TwmrPlant("p")
    p.setup(0, 1)
    p.initialize()
    assert a == pytest.approx(1.0 / (p.m11 + p.m12), rel=1e-9)  # nu' = tau / (m11 + m12), t = 1
    assert b == -a


def test_100_instantiate_free_cycles_in_one_process(fmus) -> None:
    done = run(CYCLES, str(fmus["asmc"]))
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["cycles", "100"]


def test_simulate_fmu_again_in_the_same_process(fmus) -> None:
    done = run(AGAIN, str(fmus["smc"]))
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["True", "51"]


@pytest.mark.parametrize("kind", ["twmr_plant", "asmc", "smc"])
def test_simulate_fmu_with_terminate_and_free_exits_cleanly_every_time(kind, fmus) -> None:
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        runs = list(pool.map(lambda _: run(SIMULATE, str(fmus[kind])), range(RUNS)))
    codes = [r.returncode for r in runs]
    assert codes == [0] * RUNS, next(r.stderr[-2000:] for r in runs if r.returncode)
    assert all(r.stdout.split() == ["51"] for r in runs)


def test_python_host_without_twmr_gets_a_clear_message(fmus, tmp_path) -> None:
    """`python -S` with site-packages on PYTHONPATH: fmpy and pythonfmu import, twmr (installed
    here in development mode, through a .pth file that -S skips) does not."""
    site = sysconfig.get_paths()["purelib"]
    env = {"PYTHONPATH": site, "PATH": os.environ.get("PATH", "")}
    probe = run("import importlib.util as u; print(u.find_spec('twmr'))", env=env, cwd=tmp_path)
    if probe.stdout.strip() != "None":
        pytest.skip("twmr is installed as a regular package here: -S cannot hide it")
    done = run(LOGGED, str(fmus["asmc"]), env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "LOG fmi2Instantiate failed: this FMU needs Python with twmr-cosim installed (pip " \
           f"install -e . in a checkout of twmr-cosim); the FMU's Python is {sys.executable}" \
        in done.stdout
    assert "FAILED" in done.stdout


@pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")
def test_host_that_is_not_python_gets_a_clear_message(fmus, tmp_path) -> None:
    import fmpy
    from fmpy import extract

    source = tmp_path / "host.c"
    source.write_text(C_HOST)
    host = tmp_path / "host"
    subprocess.run(["cc", str(source), f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-o",
                    str(host), "-ldl"], check=True, capture_output=True)
    unzipped = Path(extract(str(fmus["smc"])))
    lib = unzipped / "binaries" / fmpy.platform / f"Smc{fmpy.sharedLibraryExtension}"
    done = subprocess.run([str(host), str(lib), (unzipped / "resources").as_uri()],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr  # loaded (RTLD_NOW), refused, no crash
    assert "the host is not a Python process" in done.stdout and "NULL" in done.stdout


@pytest.mark.parametrize("spec", ["file", "module"])
def test_user_component_class_exports_and_runs(spec, tmp_path) -> None:
    """The class's module file travels inside the FMU: the run is in another folder."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "leaky_user.py").write_text(USER_MODULE)
    if spec == "file":
        target = f"{src / 'leaky_user.py'}:Leaky"
    else:
        sys.path.insert(0, str(src))
        target = "leaky_user:Leaky"
    try:
        fmu = export_component(target, tmp_path / "leaky.fmu", {"a": 2.0})
    finally:
        if spec == "module":
            sys.path.remove(str(src))
        sys.modules.pop("leaky_user", None)
    code = textwrap.dedent("""
        import sys
        from fmpy import simulate_fmu
        r = simulate_fmu(sys.argv[1], stop_time=1.0, output_interval=0.1,
                         start_values={'u': 1.0})
        print(r['y'][-1])
    """)
    elsewhere = tmp_path / "run"
    elsewhere.mkdir()
    done = run(code, str(fmu), cwd=elsewhere)
    assert done.returncode == 0, done.stderr[-2000:]
    expected = 0.0
    for _ in range(10):
        expected += 0.1 * (-2.0 * expected + 1.0)
    assert float(done.stdout) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("target", ["leaky_user.py:Leaky", "lib/leaky_user.py:Leaky",
                                    "./lib/../leaky_user.py:Leaky", "leaky_user:Leaky"])
def test_the_twmr_command_exports_a_class_named_relative_to_the_working_folder(
        target, tmp_path) -> None:
    """`twmr export --python` (the installed command, whose own folder is first on its path):
    a file path and a module name both resolve against the working folder, and the FMU runs
    from another folder."""
    work = tmp_path / "work"
    (work / "lib").mkdir(parents=True)
    for folder in (work, work / "lib"):
        (folder / "leaky_user.py").write_text(USER_MODULE)
    twmr = Path(sys.executable).with_name("twmr")
    done = subprocess.run([str(twmr), "export", "--python", target, "--set", "a=2.0",
                           "--out", "leaky.fmu"], cwd=work, capture_output=True, text=True,
                          timeout=300, env=dict(os.environ, PYTHONPATH=""))
    assert done.returncode == 0, done.stderr[-2000:]
    assert Path(done.stdout.strip()) == work / "leaky.fmu"
    code = textwrap.dedent("""
        import sys
        from fmpy import simulate_fmu
        r = simulate_fmu(sys.argv[1], stop_time=1.0, output_interval=0.1,
                         start_values={'u': 1.0})
        print(r['y'][-1])
    """)
    elsewhere = tmp_path / "run"
    elsewhere.mkdir()
    ran = run(code, str(work / "leaky.fmu"), cwd=elsewhere)
    assert ran.returncode == 0, ran.stderr[-2000:]
    expected = 0.0
    for _ in range(10):
        expected += 0.1 * (-2.0 * expected + 1.0)
    assert float(ran.stdout) == pytest.approx(expected, rel=1e-12)
