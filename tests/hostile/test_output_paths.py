"""Hostile result folders: `twmr run GOOD --out X` for odd X, `twmr plot` on broken results, and
re-runs that fail. A run writes only where asked (the out folder and its `.partial-<pid>` /
`.incomplete` siblings), never follows a symlinked result folder elsewhere, never destroys a
previous result or unrelated files, and refuses what it cannot do with a clean error."""
from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from tests.hostile.runner import (
    GOOD_TEXT,
    Outcome,
    assert_clean_error,
    assert_ok,
    assert_ok_or_clean_error,
    assert_writes_only_under,
    result_family,
    root_can_write,
    run_cli,
    write,
)

GOOD = "loop.yaml"
FAILING_TEXT = GOOD_TEXT.replace("height: 1.0", "height: .inf", 1)  # 'ref' yields inf at 0.1 s
assert FAILING_TEXT != GOOD_TEXT


@pytest.fixture
def base(tmp_path: Path) -> Path:
    """tmp_path holds cwd/ (where twmr runs, with loop.yaml) and elsewhere/ (must stay as is)."""
    (tmp_path / "cwd").mkdir()
    (tmp_path / "elsewhere").mkdir()
    write(tmp_path / "cwd", GOOD, GOOD_TEXT)
    write(tmp_path / "cwd", "failing.yaml", FAILING_TEXT)
    write(tmp_path / "elsewhere", "keep.txt", "precious data\n")
    return tmp_path


def run(base: Path, *args: str, timeout: float = 60) -> Outcome:
    return run_cli(list(args), base / "cwd", timeout=timeout, watched=[base])


def good_run(base: Path, out: str = "out") -> Path:
    o = run(base, "run", GOOD, "--out", out, "-q")
    assert_ok(o)
    return base / "cwd" / out


def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


# -- run --out X -------------------------------------------------------------------------------
def test_out_is_an_existing_regular_file(base: Path) -> None:
    write(base / "cwd", "out", "not a folder\n")
    o = run(base, "run", GOOD, "--out", "out")
    assert_clean_error(o, mentions=("out",))
    assert (base / "cwd" / "out").read_text() == "not a folder\n"
    assert_writes_only_under(o, [])


def test_out_under_a_regular_file(base: Path) -> None:
    write(base / "cwd", "afile", "x\n")
    o = run(base, "run", GOOD, "--out", "afile/out")
    assert_clean_error(o, mentions=("afile",))
    assert_writes_only_under(o, [])


def test_out_is_the_scenario_file(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", GOOD)
    assert_clean_error(o, mentions=(GOOD,))
    assert (base / "cwd" / GOOD).read_text() == GOOD_TEXT
    assert_writes_only_under(o, [])


def test_out_in_a_read_only_directory(base: Path) -> None:
    ro = base / "cwd" / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if root_can_write(ro):
            pytest.skip("running as root: a 0o555 folder is still writable")
        o = run(base, "run", GOOD, "--out", "ro/out")
        assert_clean_error(o, mentions=("ro",))
        assert_writes_only_under(o, [])
    finally:
        ro.chmod(0o755)


def test_out_is_a_read_only_previous_result(base: Path) -> None:
    out = good_run(base)
    before = tree(out)
    parent = base / "cwd"
    parent.chmod(0o555)
    try:
        if root_can_write(parent):
            pytest.skip("running as root: a 0o555 folder is still writable")
        o = run(base, "run", GOOD, "--out", "out")
        assert_clean_error(o, mentions=("out",))
        assert tree(out) == before
    finally:
        parent.chmod(0o755)


def test_out_with_dotdot_escaping_the_cwd(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", "../escaped/out")
    assert_ok(o)
    out = base / "escaped" / "out"
    assert (out / "result.arrows").is_file(), o.describe()
    assert_writes_only_under(o, result_family(out))


def test_out_is_a_symlink_to_a_folder_elsewhere(base: Path) -> None:
    target = base / "elsewhere" / "target"
    target.mkdir()
    write(target, "old_result.txt", "someone else's folder\n")
    os.symlink(target, base / "cwd" / "out")
    o = run(base, "run", GOOD, "--out", "out")
    assert_ok_or_clean_error(o)
    assert_writes_only_under(o, [base / "cwd"])       # never into elsewhere/
    assert (target / "old_result.txt").read_text() == "someone else's folder\n"
    assert_writes_only_under(o, result_family(base / "cwd" / "out"))  # and leaves no litter


def test_out_is_a_symlink_and_the_run_fails(base: Path) -> None:
    target = base / "elsewhere" / "target"
    target.mkdir()
    os.symlink(target, base / "cwd" / "out")
    o = run(base, "run", "failing.yaml", "--out", "out")
    assert_clean_error(o, mentions=("symbolic link",))  # refused before it runs
    assert_writes_only_under(o, [base / "cwd"])
    assert not list(target.iterdir())


def test_incomplete_name_is_a_symlink_elsewhere(base: Path) -> None:
    target = base / "elsewhere" / "target"
    target.mkdir()
    write(target, "keep.txt", "keep\n")
    os.symlink(target, base / "cwd" / "out.incomplete")
    o = run(base, "run", "failing.yaml", "--out", "out")
    assert_clean_error(o)
    assert_writes_only_under(o, [base / "cwd"])
    assert (target / "keep.txt").read_text() == "keep\n"


def test_out_in_a_symlinked_folder_is_left_alone_when_a_result_exists(base: Path) -> None:
    """A previous result reached through a symlinked parent is replaced in place, and the
    folder the link points at keeps its other files."""
    (base / "elsewhere" / "runs").mkdir()
    write(base / "elsewhere" / "runs", "notes.txt", "notes\n")
    os.symlink(base / "elsewhere" / "runs", base / "cwd" / "runs")
    o = run(base, "run", GOOD, "--out", "runs/out")
    assert_ok(o)
    assert (base / "elsewhere" / "runs" / "notes.txt").read_text() == "notes\n"
    assert_writes_only_under(o, result_family(base / "elsewhere" / "runs" / "out"))


@pytest.mark.parametrize("name", ["...yaml", ".yaml", "..yaml"])
def test_scenario_name_of_dots_without_out(base: Path, name: str) -> None:
    """Without --out the results go to results/<name>/: never into the cwd itself, never into
    results/ itself (which holds the other scenarios' results)."""
    cwd = base / "cwd"
    write(cwd, name, GOOD_TEXT)
    write(cwd / "results" / "other", "summary.json", "{}\n")
    o = run(base, "run", name)
    assert (cwd / name).read_text() == GOOD_TEXT, "the scenario file was destroyed"
    assert (cwd / GOOD).read_text() == GOOD_TEXT, "a file of the cwd was destroyed"
    assert (cwd / "results" / "other" / "summary.json").is_file(), \
        f"another scenario's result was destroyed\n{o.describe()}"
    assert_ok_or_clean_error(o)
    assert_writes_only_under(o, [cwd / "results"])
    if o.returncode == 0:
        assert not (cwd / "results" / "result.arrows").exists(), \
            f"the results were written into results/ itself, not results/<name>/\n{o.describe()}"
        results = [p for p in (cwd / "results").iterdir() if (p / "result.arrows").is_file()]
        assert results, o.describe()


def test_out_with_spaces_and_unicode(base: Path) -> None:
    name = "my results/ünïcødé ✓ run"
    o = run(base, "run", GOOD, "--out", name)
    assert_ok(o)
    assert (base / "cwd" / name / "result.arrows").is_file()
    assert_writes_only_under(o, result_family(base / "cwd" / name))


def test_out_is_dev_null(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", "/dev/null")
    assert_clean_error(o, mentions=("/dev/null",))
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode), "/dev/null was replaced"
    assert_writes_only_under(o, [])


def test_out_is_an_empty_string(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", "")
    assert_ok_or_clean_error(o)
    assert_writes_only_under(o, result_family(base / "cwd" / "results" / "loop"))


def test_out_is_the_current_folder(base: Path) -> None:
    cwd = base / "cwd"
    write(cwd, "notes.txt", "my notes\n")
    o = run(base, "run", GOOD, "--out", ".")
    assert (cwd / GOOD).is_file() and (cwd / GOOD).read_text() == GOOD_TEXT, \
        f"the scenario file was destroyed\n{o.describe()}"
    assert (cwd / "notes.txt").is_file(), f"an unrelated file was destroyed\n{o.describe()}"
    assert_ok_or_clean_error(o)
    assert_writes_only_under(o, result_family(cwd))


def test_out_is_a_folder_of_unrelated_files(base: Path) -> None:
    data = base / "cwd" / "mydata"
    write(data, "thesis.tex", "years of work\n")
    o = run(base, "run", GOOD, "--out", "mydata")
    assert (data / "thesis.tex").is_file(), \
        f"--out replaced a folder that was not a result, and its files are gone\n{o.describe()}"
    assert_ok_or_clean_error(o)


def test_out_name_too_long(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", "x" * 300)
    assert_clean_error(o)
    assert_writes_only_under(o, [])


def test_out_with_trailing_slash(base: Path) -> None:
    o = run(base, "run", GOOD, "--out", "out/")
    assert_ok(o)
    assert (base / "cwd" / "out" / "result.arrows").is_file()
    assert_writes_only_under(o, result_family(base / "cwd" / "out"))


# -- twmr plot -----------------------------------------------------------------------------------
def test_plot_an_empty_folder(base: Path) -> None:
    (base / "cwd" / "empty").mkdir()
    o = run(base, "plot", "empty")
    assert_clean_error(o, mentions=("empty",))
    assert_writes_only_under(o, [])


def test_plot_a_missing_path(base: Path) -> None:
    o = run(base, "plot", "nowhere")
    assert_clean_error(o, mentions=("nowhere",))
    assert_writes_only_under(o, [])


def test_plot_corrupt_arrows(base: Path) -> None:
    write(base / "cwd" / "bad", "result.arrows", os.urandom(4096))
    o = run(base, "plot", "bad")
    assert_clean_error(o, mentions=("result.arrows",))
    assert_writes_only_under(o, [])


def test_plot_empty_arrows(base: Path) -> None:
    write(base / "cwd" / "bad", "result.arrows", b"")
    o = run(base, "plot", "bad")
    assert_clean_error(o, mentions=("result.arrows",))
    assert_writes_only_under(o, [])


def test_plot_truncated_arrows_still_plots(base: Path) -> None:
    out = good_run(base)
    arrows = out / "result.arrows"
    data = arrows.read_bytes()
    arrows.write_bytes(data[: len(data) // 2])
    for export in ("result.csv", "result.mat"):  # exports, if the run wrote any
        (out / export).unlink(missing_ok=True)
    o = run(base, "plot", "out")
    assert_ok(o)
    assert list((out / "plots").glob("*.png")), o.describe()
    assert_writes_only_under(o, [out / "plots"])


def test_plot_csv_with_a_bad_header(base: Path) -> None:
    write(base / "cwd", "bad.csv", "this,is;not\n1,2,3,4\nx\n")
    o = run(base, "plot", "bad.csv")
    assert_clean_error(o, mentions=("bad.csv",))
    assert_writes_only_under(o, [])


def test_plot_empty_csv(base: Path) -> None:
    write(base / "cwd", "empty.csv", "")
    o = run(base, "plot", "empty.csv")
    assert_clean_error(o, mentions=("empty.csv",))
    assert_writes_only_under(o, [])


def test_plot_out_is_a_file(base: Path) -> None:
    good_run(base)
    write(base / "cwd", "afile", "x\n")
    o = run(base, "plot", "out", "--out", "afile")
    assert_clean_error(o, mentions=("afile",))
    assert (base / "cwd" / "afile").read_text() == "x\n"


# -- nothing already computed is lost -----------------------------------------------------------
def test_failing_rerun_keeps_the_previous_result(base: Path) -> None:
    out = good_run(base)
    before = tree(out)
    o = run(base, "run", "failing.yaml", "--out", "out")
    assert_clean_error(o, mentions=("ref", "out.incomplete"))
    assert tree(out) == before, "the first result changed"
    assert (out / "result.arrows").read_bytes() == before["result.arrows"]
    assert_writes_only_under(o, result_family(out))


def test_rerun_refused_at_load_touches_nothing(base: Path) -> None:
    good_run(base)
    write(base / "cwd", "broken.yaml", GOOD_TEXT.replace("kind: gain", "kind: gian"))
    o = run(base, "run", "broken.yaml", "--out", "out")
    assert_clean_error(o, mentions=("broken.yaml", "gian"))
    assert_writes_only_under(o, [])


def test_nan_run_leaves_readable_partial_results(base: Path) -> None:
    import twmr

    o = run(base, "run", "failing.yaml", "--out", "out")
    assert_clean_error(o, mentions=("ref", "out.incomplete"))
    partial = base / "cwd" / "out.incomplete"
    assert not (base / "cwd" / "out").exists(), "a failed run took the final name"
    result = twmr.read_result(partial)
    assert len(result) > 0, "no rows were kept"
    assert result.status == "failed"
    assert result.time[-1] < 0.11 + 1e-9
    assert_writes_only_under(o, result_family(base / "cwd" / "out"))


def test_nan_run_with_plot_plots_the_partial_results(base: Path) -> None:
    o = run(base, "run", "failing.yaml", "--out", "out", "--plot")
    assert_clean_error(o, mentions=("out.incomplete",))
    assert list((base / "cwd" / "out.incomplete" / "plots").glob("*.png")), o.describe()
    assert_writes_only_under(o, result_family(base / "cwd" / "out"))
