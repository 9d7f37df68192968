"""Results: the crash-consistent store, exports read by the libraries made for them (pandas,
scipy, pyarrow), thousands of columns, a re-run that never destroys the previous result."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import scipy.io

import twmr
from twmr.observers.store import FILENAME, read_store
from twmr.plots import plot_result

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"


@pytest.fixture()
def run(tmp_path) -> twmr.Result:
    return twmr.simulate(twmr.load(FIXTURE), tmp_path / "run", formats=("csv", "mat", "parquet"))


def test_csv_reads_with_pandas_as_is_and_units_sit_beside(run) -> None:
    df = pd.read_csv(run.folder / "result.csv")
    assert list(df.columns) == ["time", "plant.u", "plant.y", "ctrl.y"]
    np.testing.assert_array_equal(df["plant.y"].to_numpy(), run["plant.y"])
    units = json.loads((run.folder / "units.json").read_text())
    assert units["time"] == "s"
    back = twmr.read_result(run.folder / "result.csv")
    np.testing.assert_array_equal(back.values, run.values)


def test_mat_and_parquet_carry_values_and_units(run) -> None:
    m = scipy.io.loadmat(run.folder / "result.mat")
    np.testing.assert_array_equal(np.ravel(m["plant_y"]), run["plant.y"])
    assert str(np.ravel(np.ravel(m["units"])[0])[0]) == "s"
    table = pq.read_table(run.folder / "result.parquet")
    np.testing.assert_array_equal(table.column("ctrl.y").to_numpy(), run["ctrl.y"])
    assert table.schema.field("time").metadata[b"unit"] == b"s"
    for name in ("result.mat", "result.parquet"):
        np.testing.assert_array_equal(twmr.read_result(run.folder / name).values, run.values)


def test_to_pandas_has_time_columns_and_units(run) -> None:
    df = twmr.read_result(run.folder).to_pandas()
    assert df.columns[0] == "time" and len(df) == 51
    assert df.attrs["units"]["time"] == "s"
    assert run.summary["status"] == "completed" and run.summary["steps_done"] == 100


def test_store_stays_readable_when_its_last_chunk_is_torn(tmp_path) -> None:
    text = FIXTURE.read_text().replace("stop: 1.0", "stop: 50.0").replace("decimation: 2",
                                                                           "decimation: 1")
    result = twmr.simulate(twmr.load(text), tmp_path / "run")
    raw = (result.folder / FILENAME).read_bytes()
    torn = tmp_path / "torn.arrows"
    torn.write_bytes(raw[: len(raw) * 3 // 4])
    _columns, _, values, intact = read_store(torn)
    assert not intact and 0 < len(values) < len(result)
    np.testing.assert_array_equal(values, result.values[: len(values)])


def test_a_store_cut_short_between_its_two_reads_gives_the_rows_read(tmp_path,
                                                                      monkeypatch) -> None:
    """read_store sizes the batches from the file mapped, then reads them again: a file cut
    short in between (a run overwriting it) gives the whole batches it still has, not an
    error."""
    import pyarrow

    text = FIXTURE.read_text().replace("stop: 1.0", "stop: 50.0").replace("decimation: 2",
                                                                           "decimation: 1")
    result = twmr.simulate(twmr.load(text), tmp_path / "run")
    raw = (result.folder / FILENAME).read_bytes()
    shorter = tmp_path / "shorter.arrows"
    shorter.write_bytes(raw[: len(raw) // 2])
    whole = read_store(result.folder / FILENAME)
    assert whole[3] and len(whole[2]) == len(result)
    real = pyarrow.OSFile
    monkeypatch.setattr(pyarrow, "OSFile", lambda path, *a: real(str(shorter), *a))
    _columns, _, values, intact = read_store(result.folder / FILENAME)
    assert not intact and 0 < len(values) < len(result)
    np.testing.assert_array_equal(values, result.values[: len(values)])


def test_three_thousand_columns(tmp_path) -> None:
    scenario = {"components": {f"c{i}": {"kind": "constant", "parameters": {"value": float(i)}}
                               for i in range(3000)},
                "experiment": {"stop": 0.05, "step": 0.01}}
    result = twmr.simulate(twmr.load(scenario), tmp_path / "wide", formats=("csv", "parquet"))
    assert len(result.columns) == 3001 and len(result) == 6
    assert result["c2999.y"][-1] == 2999.0
    assert pd.read_csv(result.folder / "result.csv").shape == (6, 3001)


def test_failed_rerun_keeps_the_previous_result(tmp_path) -> None:
    out = tmp_path / "run"
    good = twmr.simulate(twmr.load(FIXTURE), out)
    bad = twmr.load(FIXTURE, ["ref.height=.inf", "ref.time=0.5"])
    with pytest.raises(twmr.api.CosimError) as err:
        twmr.simulate(bad, out)
    assert err.value.partial_results == out.with_name("run.incomplete")
    kept = twmr.read_result(out)
    np.testing.assert_array_equal(kept.values, good.values)
    partial = twmr.read_result(out.with_name("run.incomplete"))
    assert partial.status == "failed" and 0 < len(partial) < len(good)
    assert not list(tmp_path.glob("run.partial-*"))


def test_plots_are_written(run) -> None:
    paths = plot_result(run.data, run.units, run.folder / "plots")
    assert {p.name for p in paths} == {f"{n}{s}" for n in ("plant_u", "plant_y", "ctrl_y")
                                       for s in (".png", ".svg")}
    assert all(p.stat().st_size > 1000 for p in paths)
    assert (run.folder / "plots" / "ctrl_y.svg").read_text().lstrip().startswith("<?xml")


def test_summary_json_is_standard_json_and_reads_back_its_infinities(tmp_path) -> None:
    """A strict JSON reader (no NaN/Infinity literals) takes summary.json; the strings it holds
    for non-finite numbers read back as floats."""
    import json
    import math

    from twmr.observers.summary import write_summary
    from twmr.result import _summary

    document = {"realtime_factor": math.inf, "signals": {"x": {"min": -math.inf,
                                                              "rms": math.nan, "max": 2.5}}}
    write_summary(document, tmp_path / "summary.json")
    text = (tmp_path / "summary.json").read_text()

    def refuse(name: str) -> None:
        raise ValueError(f"non-standard JSON literal {name}")

    strict = json.loads(text, parse_constant=refuse)
    assert strict["realtime_factor"] == "Infinity" and strict["signals"]["x"]["rms"] == "NaN"
    back = _summary(tmp_path)
    assert back["realtime_factor"] == math.inf and back["signals"]["x"]["min"] == -math.inf
    assert math.isnan(back["signals"]["x"]["rms"]) and back["signals"]["x"]["max"] == 2.5


@pytest.mark.parametrize("name", ["csv", "mat", "parquet"])
def test_every_export_reads_back_every_double_exactly(tmp_path, name) -> None:
    """The awkward doubles (1/3, the smallest subnormal, -0, +-inf, NaN, 2^53 + 2) come back bit
    for bit from each export (CSV: the shortest form that reads back to the same double, read
    by numpy and by pandas)."""
    from twmr.observers.writers import result_formats

    fmt = result_formats([name])[name]
    column = [0.0, 1 / 3, 5e-324, -0.0, np.inf, -np.inf, np.nan, 2.0**53 + 2,
              -1.2345678901234567e-89]
    values = np.column_stack([np.arange(len(column), dtype=float), column])
    path = tmp_path / f"r{fmt.suffix}"
    fmt.write(path, ["time", "a.b[1]"], ["s", "m"], values)
    columns, units, back = fmt.read(path)
    assert columns == ["time", "a.b[1]"] and units == ["s", "m"]
    assert np.array_equal(back, values, equal_nan=True)
    assert np.array_equal(np.signbit(back), np.signbit(values))  # -0 stays -0
    if name == "csv":
        read = pd.read_csv(path)["a.b[1]"].to_numpy()
        assert np.array_equal(read, values[:, 1], equal_nan=True)


def test_a_mat_variable_is_compressed_only_where_it_shrinks(tmp_path) -> None:
    """The time (its regular bits), a constant and a stepped column are stored zlib-compressed,
    a noise-like one raw (it would shrink a few per cent at ten times the cost); scipy reads
    every one back exactly.
    Parquet keeps a dictionary for the constant column only; pyarrow reads both back."""
    import pyarrow.parquet as pq

    from twmr.observers import writers

    n = 200_000
    values = np.column_stack([np.arange(n) * 1e-3, np.full(n, 2.5),
                              np.repeat(np.arange(20.0), n // 20),
                              np.random.default_rng(5).standard_normal(n)])
    columns = ["time", "c.y", "s.y", "w.y"]
    fmt = writers.result_formats(["mat", "parquet"])
    fmt["mat"].write(tmp_path / "r.mat", columns, ["s", "", "", ""], values)
    data = (tmp_path / "r.mat").read_bytes()
    kinds, at = [], 128
    while at < len(data):
        kind, size = struct.unpack_from("<II", data, at)
        kinds.append(kind)
        at += 8 + size + (-size % 8 if kind != 15 else 0)
    assert kinds[:4] == [15, 15, 15, 14]  # the noise raw (miMATRIX), the others compressed
    m = scipy.io.loadmat(tmp_path / "r.mat")
    assert np.array_equal(np.column_stack([np.ravel(m[n]) for n in
                                           ("time", "c_y", "s_y", "w_y")]), values)
    fmt["parquet"].write(tmp_path / "r.parquet", columns, ["s", "", "", ""], values)
    meta = pq.ParquetFile(tmp_path / "r.parquet").metadata.row_group(0)
    dictionary = [any("DICTIONARY" in e for e in meta.column(j).encodings)
                  for j in range(4)]
    assert dictionary == [False, True, False, False]
    assert np.array_equal(pq.read_table(tmp_path / "r.parquet").to_pandas().to_numpy(), values)


def test_exports_made_in_pieces_keep_row_order(tmp_path, monkeypatch) -> None:
    """CSV text formatted 7 rows per task on several threads, MAT variables compressed each on
    its own: pandas and scipy read back every row in order, and scipy lists every variable."""
    from twmr.observers import writers

    monkeypatch.setattr(writers, "CSV_ROWS", 7)
    values = np.column_stack([np.arange(1000) * 1e-3,
                              np.random.default_rng(3).standard_normal((1000, 4))])
    columns = ["time", "p.y[1]", "p.y[2]", "q.y", "r,s"]
    fmt = writers.result_formats(["csv", "mat"])
    fmt["csv"].write(tmp_path / "r.csv", columns, ["s", "m", "m", "", ""], values)
    assert np.array_equal(pd.read_csv(tmp_path / "r.csv").to_numpy(), values)
    fmt["mat"].write(tmp_path / "r.mat", columns, ["s", "m", "m", "", ""], values)
    listed = {name for name, _shape, _kind in scipy.io.whosmat(tmp_path / "r.mat")}
    assert listed == {"time", "p_y_1", "p_y_2", "q_y", "r_s", "columns", "variables", "units"}
    m = scipy.io.loadmat(tmp_path / "r.mat")
    assert np.array_equal(np.column_stack([np.ravel(m[n]) for n in
                                           ("time", "p_y_1", "p_y_2", "q_y", "r_s")]), values)


@pytest.mark.parametrize(("text", "columns", "values"), [
    (b"\xef\xbb\xbftime,a\n0,1\n1,4\n", ["time", "a"], [[0, 1], [1, 4]]),  # Excel's BOM
    (b"time;a\r\n0;1,5\r\n1;2,25\r\n", ["time", "a"], [[0, 1.5], [1, 2.25]]),  # decimal comma
    (b"time\tTemp \xb0C\n0\t1\n1\t2\n", ["time", "Temp \u00b0C"], [[0, 1], [1, 2]]),  # Latin-1
    (b"time,a\n0,\n1,x\n", ["time", "a"], [[0, np.nan], [1, np.nan]]),  # empty and text: NaN
    (b"# logger 2.1\n# 10 Hz\ntime,a\n0,1\n# paused\n1,2\n", ["time", "a"], [[0, 1], [1, 2]]),
], ids=["bom", "semicolon", "tab-latin1", "nan", "comments"])
def test_csv_files_from_spreadsheets_and_loggers_read(tmp_path, text, columns, values) -> None:
    (tmp_path / "data.csv").write_bytes(text)
    result = twmr.read_result(tmp_path / "data.csv")
    assert result.columns == columns
    np.testing.assert_array_equal(result.values, np.array(values, dtype=float))


@pytest.mark.parametrize(("text", "said"), [
    (b"time,a,b\n0,1,2\n1,2\n", "line 3 has 2 values where the rows before it have 3"),
    (b"time;a\n0;1\n1;2;3\n", "line 3 has 3 values where the rows before it have 2"),
    (b"# logger\ntime,a\n0,1\n1,2,3\n", "line 4 has 3 values where the rows before it have 2"),
    (b"time,a,b\n0,1\n1,2\n", "the header names 3 column(s) but the rows hold 2 value(s)"),
    (b"", "the file is empty"),
], ids=["short-row", "long-row-semicolon", "after-comments", "short-header", "empty"])
def test_a_csv_of_uneven_rows_is_named_by_its_line(tmp_path, text, said) -> None:
    (tmp_path / "data.csv").write_bytes(text)
    with pytest.raises(twmr.CosimError, match=r"data\.csv: ") as err:
        twmr.read_result(tmp_path / "data.csv")
    assert said in str(err.value) and "Fix:" in str(err.value)


def test_a_mat_file_saved_by_matlab_or_a_logger_reads_as_columns(tmp_path) -> None:
    """Not twmr's export: vectors (row or column), a matrix as name[j], a struct's fields as
    struct.field (Simulink's 'structure with time'), time first; scalars and text left out."""
    t = np.arange(5) * 0.1
    scipy.io.savemat(tmp_path / "log.mat", {
        "x": t ** 2, "Ts": 0.1, "note": "bench 3", "time": t.reshape(1, -1),
        "pose": np.column_stack([t, 2 * t])})
    log = twmr.read_result(tmp_path / "log.mat")
    assert log.columns == ["time", "x", "pose[1]", "pose[2]"]
    np.testing.assert_array_equal(log.values, np.column_stack([t, t ** 2, t, 2 * t]))
    scipy.io.savemat(tmp_path / "yout.mat", {"yout": {"signals": {"values": np.column_stack(
        [t, -t])}, "time": t}})
    yout = twmr.read_result(tmp_path / "yout.mat")
    assert yout.columns == ["yout.time", "yout.signals.values[1]", "yout.signals.values[2]"]
    np.testing.assert_array_equal(yout.values[:, 2], -t)


@pytest.mark.parametrize(("content", "said"), [
    ({"time": np.arange(5.0), "x": np.arange(3.0)},
     "its vectors differ in length: time (5), x (3)"),
    ({"k": 3.0, "name": "abc"}, "no numeric vector in this MAT file"),
], ids=["uneven", "no-vector"])
def test_a_foreign_mat_file_without_columns_is_said_plainly(tmp_path, content, said) -> None:
    scipy.io.savemat(tmp_path / "log.mat", content)
    with pytest.raises(twmr.CosimError, match="Fix:") as err:
        twmr.read_result(tmp_path / "log.mat")
    assert said in str(err.value)


def test_a_matlab_v73_file_is_refused_with_the_fix(tmp_path) -> None:
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116, b" ")
    (tmp_path / "v73.mat").write_bytes((header + bytes(8) + b"\x00\x02IM").ljust(512, b"\x00")
                                       + b"\x89HDF\r\n\x1a\n" + bytes(64))
    with pytest.raises(twmr.CosimError, match=r"v7\.3 file") as err:
        twmr.read_result(tmp_path / "v73.mat")
    assert "-v7" in str(err.value)


def test_a_loggers_parquet_with_timestamps_reads_time_in_seconds(tmp_path) -> None:
    """pandas' DatetimeIndex (time-zone aware, unnamed) and a timedelta column become seconds
    from the first sample, exact to the nanosecond; the time goes first; text is left out."""
    stamps = pd.date_range("2026-01-01 08:00", periods=4, freq="250ms", tz="Europe/Berlin")
    pd.DataFrame({"x": np.arange(4.0), "label": list("abcd")}, index=stamps).to_parquet(
        tmp_path / "log.parquet")
    log = twmr.read_result(tmp_path / "log.parquet")
    assert log.columns == ["time", "x"] and log.units["time"] == "s"
    assert log.values[:, 0].tolist() == [0.0, 0.25, 0.5, 0.75]
    pd.DataFrame({"x": [1.0, 2.0], "t": pd.to_timedelta([5, 105], unit="ms")}).to_parquet(
        tmp_path / "delta.parquet", index=False)
    delta = twmr.read_result(tmp_path / "delta.parquet")
    assert delta.columns == ["t", "x"] and delta.values[:, 0].tolist() == [0.005, 0.105]


def test_a_loggers_units_row_below_the_header_gives_the_units(tmp_path) -> None:
    (tmp_path / "log.csv").write_bytes(b"Zeit;Weg;Winkel\n[s];[mm];rad\n0;1,5;0\n1;2,5;\n")
    log = twmr.read_result(tmp_path / "log.csv")
    assert log.units == {"Zeit": "s", "Weg": "mm", "Winkel": "rad"}
    np.testing.assert_array_equal(log.values, [[0.0, 1.5, 0.0], [1.0, 2.5, np.nan]])
    (tmp_path / "plain.csv").write_text("time,x\n0,1\n1,2\n")  # a first row of numbers: data
    assert twmr.read_result(tmp_path / "plain.csv").values.tolist() == [[0, 1], [1, 2]]
    (tmp_path / "na.csv").write_text("time,x\nNA,N/A\n1,2\n")  # a row of missing values: data
    na = twmr.read_result(tmp_path / "na.csv")
    assert na.units == {"time": "", "x": ""} and len(na) == 2
