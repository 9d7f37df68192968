"""Hostile source-only FMUs: building an FMU runs its code, so it happens only when the user asks
(`compile: true` or `twmr fmu build`), never at `twmr check`; a file name carrying build-system
syntax (the CMake-cache injection that once ran a command at `twmr check`) is refused before any
tool sees it, whatever was asked; a build that hangs is stopped by its timeout."""
from __future__ import annotations

import os
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.hostile.runner import assert_clean_error, assert_ok, run_cli, write
from tests.integration.test_fmu_sources import SCENARIO, source_only_lag2
from twmr.fmi.cexport import export_c_fmu

pytestmark = pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")

#: the injected name: a newline (&#10; in the XML), then a CMake cache entry running a shell
INJECTION = "lag2.c&#10;CMAKE_C_COMPILER_LAUNCHER:STRING=/bin/sh;-c;touch {marker};"


def _rewrite(fmu: Path, out: Path, edit: dict[str, tuple[str, str]],
             extra: dict[str, bytes] | None = None) -> Path:
    """A copy of `fmu` with text replaced in some members ({member: (old, new)}) and members
    added."""
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(out, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name in edit:
                old, new = edit[name]
                assert old.encode() in data
                data = data.replace(old.encode(), new.encode())
            zout.writestr(name, data)
        for name, data in (extra or {}).items():
            zout.writestr(name, data)
    return out


def fmi2_injection(folder: Path, marker: Path) -> Path:
    """lag2 from sources, its modelDescription.xml <SourceFiles> naming the hostile file."""
    hostile = INJECTION.format(marker=marker)
    return _rewrite(source_only_lag2(folder), folder / "evil2.fmu",
                    {"modelDescription.xml": ('<File name="lag2.c"/>',
                                              f'<File name="{hostile}"/>')})


def fmi3_injection(folder: Path, marker: Path) -> Path:
    """An FMI 3 C export without its binary, its buildDescription.xml naming the hostile file."""
    full = export_c_fmu("integrator", folder / "full3.fmu", {"k": 2.0}, fmi=3)
    bare = folder / "bare3.fmu"
    with zipfile.ZipFile(full) as zin, zipfile.ZipFile(bare, "w") as zout:
        for name in zin.namelist():
            if not name.startswith("binaries/"):
                zout.writestr(name, zin.read(name))
    hostile = INJECTION.format(marker=marker).replace("lag2.c", "fmi3.c")
    return _rewrite(bare, folder / "evil3.fmu",
                    {"sources/buildDescription.xml": ('<SourceFile name="fmi3.c"/>',
                                                      f'<SourceFile name="{hostile}"/>')})


def listing_injection(folder: Path, marker: Path) -> Path:
    """Honest lag2 sources, plus a member of sources/ whose name carries the same payload."""
    name = "sources/x.c\nCMAKE_C_COMPILER_LAUNCHER:STRING=/bin/sh;-c;touch " + str(marker)
    return _rewrite(source_only_lag2(folder), folder / "evil_listing.fmu", {},
                    {name: b"int x;\n"})


def scenario(folder: Path, fmu: Path, extra: str = "", name: str = "s.yaml") -> Path:
    text = SCENARIO % fmu
    return write(folder, name, text.replace("T: 0.25", f"T: 0.25{extra}"))


@pytest.mark.parametrize("make, commands", [
    (fmi2_injection, ("check", "run", "run compile", "fmu build")),
    (fmi3_injection, ("check", "run compile"))], ids=["fmi2", "fmi3"])
def test_cmake_injection_runs_nothing_at_check_run_compile_or_build(tmp_path, make,
                                                                    commands) -> None:
    marker = tmp_path / "MARKER"
    fmu = make(tmp_path, marker)
    plain = scenario(tmp_path, fmu)
    opted = scenario(tmp_path, fmu, ", compile: true", "opted.yaml")
    arguments = {"check": ["check", plain], "run": ["run", plain, "--out", "r1"],
                 "run compile": ["run", opted, "--out", "r2"], "fmu build": ["fmu", "build", fmu]}
    for command in commands:
        o = run_cli(arguments[command], tmp_path)
        assert not marker.exists(), f"the injected command ran\n{o.describe()}"
        assert_clean_error(o, mentions=[fmu.name, "CMAKE_C_COMPILER_LAUNCHER"])
        assert "not a plain C or C++ file name" in o.stderr
    assert not (tmp_path / "evil2.linux64.fmu").exists()


def test_a_hostile_name_in_the_sources_folder_is_refused(tmp_path) -> None:
    marker = tmp_path / "MARKER"
    fmu = listing_injection(tmp_path, marker)
    o = run_cli(["run", scenario(tmp_path, fmu, ", compile: true"), "--out", "r"], tmp_path)
    assert_clean_error(o, mentions=[fmu.name, "sources/ folder", "not a plain file name"])
    assert not marker.exists()
    assert not (tmp_path / "r").exists()


def test_without_opt_in_an_honest_source_fmu_is_refused_naming_both_ways(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    for command in ("check", "run"):
        o = run_cli([command, scenario(tmp_path, fmu)], tmp_path)
        para = assert_clean_error(o, mentions=[fmu.name, "compile: true", "twmr fmu build",
                                               "s.yaml"])
        assert len(para) == 1  # one paragraph, one line


def _lag2_ok(folder: Path) -> None:
    result = twmr.read_result(folder)
    expected = 2.0 * 1.5 * (1.0 - np.exp(-result["time"] / 0.25))
    np.testing.assert_allclose(result["lag.y[1]"], expected, atol=1e-12)
    assert len(result["time"]) == 101


def test_compile_true_builds_and_runs_an_honest_source_fmu(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    o = run_cli(["run", scenario(tmp_path, fmu, ", compile: true"), "--out", "r", "-q"],
                tmp_path)
    assert_ok(o)
    _lag2_ok(tmp_path / "r")
    assert zipfile.ZipFile(fmu).namelist() == ["modelDescription.xml", "sources/lag2.c"]


def test_fmu_build_writes_an_fmu_that_runs_without_opt_in(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    o = run_cli(["fmu", "build", fmu, "--out", "built.fmu"], tmp_path)
    assert_ok(o)
    built = tmp_path / "built.fmu"
    assert o.stdout.strip() == "built.fmu"
    assert "binaries/linux64/lag2.so" in zipfile.ZipFile(built).namelist()
    o = run_cli(["run", scenario(tmp_path, built), "--out", "r", "-q"], tmp_path)
    assert_ok(o)
    _lag2_ok(tmp_path / "r")
    again = run_cli(["fmu", "build", built], tmp_path)  # nothing left to build
    assert_clean_error(again, mentions=["built.fmu", "nothing to build"])


def test_a_build_that_hangs_is_stopped_by_its_timeout(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    pid_file = tmp_path / "compiler.pid"
    cc = write(tmp_path, "slow-cc", f"#!/bin/sh\nsleep 300 &\necho $! > {pid_file}\nwait\n")
    cc.chmod(0o755)
    env = {**os.environ, "CC": str(cc)}
    o = run_cli(["run", scenario(tmp_path, fmu, ", compile: true, compile_timeout: 1"),
                 "--out", "r"], tmp_path, timeout=30, env=env)
    assert_clean_error(o, mentions=[fmu.name, "did not finish within 1 s", "compile_timeout"])
    assert o.elapsed < 20
    stat = Path(f"/proc/{pid_file.read_text().strip()}/stat")
    assert not stat.exists() or stat.read_text().split(") ")[1].startswith("Z"), \
        "the compiler's child outlived the timeout"
