"""Hostile FMU files and an early Ctrl-C: each answered by a one-paragraph error that names what is
at fault in words (not a zip, a folder, no model description, a schema error, a binary that does
not load), never Python's own exception text ("[Errno 2]", "UnboundLocalError", ...)."""
from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from tests.hostile.runner import assert_clean_error, run_cli, write
from tests.integration.test_fmu_sources import source_only_lag2

PYTHON_TEXT = ("[Errno", "Error:", "Exception:", "local variable", "NoneType", "KeyError")


def _fmu(folder: Path, name: str, members: dict[str, bytes | str]) -> Path:
    path = folder / name
    with zipfile.ZipFile(path, "w") as z:
        for member, data in members.items():
            z.writestr(member, data)
    return path


def _description(folder: Path) -> str:
    return zipfile.ZipFile(source_only_lag2(folder)).read("modelDescription.xml").decode()


def _cases(folder: Path) -> dict[str, tuple[Path, str]]:
    md = _description(folder)
    (folder / "folder.fmu").mkdir()
    write(folder, "text.fmu", "not a zip\n")
    return {
        "text": (folder / "text.fmu", "it is not a zip archive"),
        "folder": (folder / "folder.fmu", "it is a folder"),
        "no description": (_fmu(folder, "nomd.fmu", {"a.txt": "a"}),
                           "no modelDescription.xml"),
        "unknown element": (_fmu(folder, "schema.fmu",
                                 {"modelDescription.xml": md.replace("<Real", "<Rxal", 1)}),
                            "does not follow the FMI schema (ERROR (line"),
    }


@pytest.mark.parametrize("case", ["text", "folder", "no description", "unknown element"])
def test_an_unreadable_fmu_is_named_in_words(tmp_path, case) -> None:
    fmu, words = _cases(tmp_path)[case]
    o = run_cli(["inspect", fmu], tmp_path)
    text = "\n".join(assert_clean_error(o, mentions=[fmu.name, words]))
    assert not any(t in text for t in PYTHON_TEXT), o.describe()


@pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")
@pytest.mark.parametrize("isolate", [False, True])
def test_a_binary_that_does_not_load_is_named_and_the_run_ends_cleanly(tmp_path,
                                                                       isolate) -> None:
    """A damaged library, and one without the FMI functions: fmpy used to leave the process in
    the (then deleted) unzip folder, so the run ended with 'No such file or directory'."""
    md = _description(tmp_path)
    write(tmp_path, "empty.c", "int nothing;\n")
    subprocess.run(["cc", "-shared", "-fPIC", str(tmp_path / "empty.c"), "-o",
                    str(tmp_path / "empty.so")], check=True)
    cases = {"damaged.fmu": (b"garbage", "file too short"),
             "nosymbols.fmu": ((tmp_path / "empty.so").read_bytes(),
                               "it lacks the FMI function fmi2")}
    for name, (library, words) in cases.items():
        fmu = _fmu(tmp_path, name, {"modelDescription.xml": md,
                                    "binaries/linux64/lag2.so": library})
        scenario = write(tmp_path, "s.yaml", f"components:\n  lag: {{kind: fmu, parameters: "
                         f"{{path: {fmu}, isolate: {str(isolate).lower()}}}}}\nopen: [lag.u]\n"
                         f"experiment: {{start: 0.0, stop: 0.1, step: 0.01}}\n")
        o = run_cli(["run", scenario, "--out", "r"], tmp_path)
        text = "\n".join(assert_clean_error(o, mentions=[name, "cannot be loaded", words]))
        assert "No such file or directory" not in text and "Exception:" not in text


#: a KeyboardInterrupt raised when `module` is first imported, then `twmr check` as the entry
#: point runs it (what Ctrl-C in the first tenths of a second does, without timing)
_INTERRUPT_AT = """
import builtins, runpy, sys
real = builtins.__import__
def hook(name, *args, **kwargs):
    if name == {module!r} and name not in sys.modules:
        raise KeyboardInterrupt
    return real(name, *args, **kwargs)
builtins.__import__ = hook
sys.argv = ["twmr", "check", "nothing.yaml"]
runpy.run_module("twmr.cli", run_name="__main__")
"""


@pytest.mark.parametrize("module", ["twmr.core.errors", "argparse"])
def test_ctrl_c_while_twmr_starts_is_one_line_and_status_130(tmp_path, module) -> None:
    done = subprocess.run([sys.executable, "-c", _INTERRUPT_AT.format(module=module)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines() == \
        ["interrupted (Ctrl-C) while twmr was starting; nothing was done."]
