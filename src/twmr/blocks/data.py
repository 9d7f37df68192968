"""`Data` (kind `data`): measured samples played as an output — the columns `columns` of a file
(CSV, Parquet, .mat, a twmr run's folder or `result.arrows`: `twmr.blocks.datafiles`) over its
`time_column`, held or linear between samples, held, extended or NaN outside them, shifted by
`time_offset` and scaled by `scale`. Its port takes the columns' unit. The samples become the
block's `times` and `values` when the scenario is built, so the run, the compiled loop and an
exported FMU play the same table; without a file they are given inline."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, ClassVar

from twmr.blocks import data_kernels as dk
from twmr.blocks import tables
from twmr.blocks.datafiles import read_samples
from twmr.blocks.tables import Problems
from twmr.core.component import Component
from twmr.core.ctwin import Choice, CTwin, checked, elements
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Output, Parameter


class Data(Component):
    """y(t): n columns of measured samples, held or linear between them.

    From `file` (its `columns` over `time_column`) or, without a file, from `times` and
    `values` given inline (row by row, n per time)."""

    kind = "data"
    sized_by: ClassVar[dict[str, str]] = {"y": "n"}
    construction_parameters = ("file", "columns", "time_column", "unit", "database", "protocol")
    file = Parameter("", type=STRING, description="the samples: a CSV, Parquet or .mat file, "
                     "or a run's folder, relative to the scenario ('': times and values inline)")
    columns = Parameter((), type=STRING, size=0, description="the file's columns played, one "
                        "per element of y")
    time_column = Parameter("time", type=STRING, description="the file's column of times [s]")
    database = Parameter("", type=STRING, description="a CAN database (DBC, ARXML, KCD) "
                         "decoding `file` as a CAN frame log (.blf, .asc, .log, .trc, a run's "
                         "<bus>_frames.arrows), its columns 'Message.Signal' ('': no log)")
    protocol = Parameter("", type=STRING, description="a drive protocol (odrive, cia402) "
                         "decoding `file` as a CAN frame log as `twmr replay` does, its columns "
                         "'<node>.<signal>' ('0.speed'; '': no log)")
    unit = Parameter("", type=STRING, description="the unit of y ('': the columns' own)")
    n = Parameter(1, type=INTEGER, min=1, description="number of elements (the columns)")
    times = Parameter((0.0, 1.0), size=0, unit="s", description="sample times, non-decreasing "
                      "(a repeated time: a jump); from the file when one is given")
    values = Parameter((0.0, 0.0), size=0, description="the samples row by row, n per time; "
                       "from the file when one is given")
    interpolation = Parameter("linear", type=STRING, description="between samples: linear | "
                              "hold")
    extrapolation = Parameter("hold", type=STRING, description="outside the samples: hold (the "
                              "end sample) | linear (the end segment extended) | error (NaN: "
                              "the run stops)")
    time_offset = Parameter(0.0, unit="s", description="the sample at time s plays at run time "
                            "s + time_offset")
    scale = Parameter(1.0, description="y = scale * sample")
    y = Output(0.0)

    def __init__(self, name: str = "", unit: str = "", **parameters: Any):
        """Its port in `unit`."""
        super().__init__(name)
        self.set_parameter("unit", unit)
        var = dataclasses.replace(self.variables["y"], unit=unit)
        var.name = "y"
        self.variables["y"] = var
        for key, value in sorted(parameters.items(), key=lambda kv: kv[0] != "n"):
            self.set_parameter(key, value)

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> Data:
        """The samples of `file` (relative to `base_dir`) read into `times` and `values`."""
        file = str(construction.get("file", "") or "")
        if not file:
            return cls(name, **construction)
        path = Path(file) if Path(file).is_absolute() else base_dir / file
        columns = tuple(construction.get("columns", ()))
        if not columns:
            raise ValueError(f"file '{file}' is given and columns is empty; name the file's "
                             f"columns to play")
        database = str(construction.get("database", "") or "")
        db = None if not database else Path(database) if Path(database).is_absolute() \
            else base_dir / database
        protocol = str(construction.get("protocol", "") or "")
        if db is not None and protocol:
            raise ValueError(f"database '{database}' and protocol '{protocol}' are both given; "
                             f"a frame log is decoded by one of them")
        samples = read_samples(path, columns, str(construction.get("time_column", "time")), db,
                               protocol)
        unit = str(construction.get("unit", "") or "")
        if unit and samples.unit and unit != samples.unit:
            raise ValueError(f"unit '{unit}' is given and the file's columns are in "
                             f"'{samples.unit}'; leave unit out, or convert the file")
        return cls(name, **{**construction, "file": str(path), "unit": unit or samples.unit,
                            **({"database": str(db)} if db is not None else {})},
                   n=len(columns), times=samples.times, values=samples.values.ravel())

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"times": [0.0, 3 * h, 3 * h, 7 * h], "values": [0.0, 1.5, -2.0, 4.0]},
                {"n": 3, "times": [h, 2 * h, 6 * h],
                 "values": [1.0, 2.0, 3.0, -1.0, 0.5, 9.0, 4.0, 4.0, -4.0]},
                {"n": 2, "times": [0.0, 10 * h], "values": [0.0, 1.0, 5.0, -5.0]})

    def check(self, given: frozenset[str]) -> Problems:
        if self.file and given & {"times", "values"}:
            key = "times" if "times" in given else "values"
            return [(key, f"{key} is given and so is file '{self.file}'.", "give the samples "
                     "one way: a file with columns, or times and values inline.")]
        if not self.file and self.columns:
            return [("columns", "columns are named and no file is given.", "give the file "
                     "the columns are in, or leave columns out.")]
        if self.file and len(self.columns) != self.n:
            return [("n", f"n is {self.n} and {len(self.columns)} columns are played.",
                     "leave n out: it is the number of columns.")]
        return (tables.choice("interpolation", self.interpolation, tables.INTERPOLATIONS) or
                tables.choice("extrapolation", self.extrapolation, tables.EXTRAPOLATIONS) or
                _at_least_two(self.times) or
                tables.increasing("times", self.times, strict=False) or
                tables.same_length("values", self.values, self.n * len(self.times),
                                   "n per time, row by row"))

    def _params(self) -> dk.DataParams:
        n = int(self.n)
        return dk.DataParams(tables.array(self.times), tables.array(self.values), float(n),
                             tables.INTERPOLATIONS[self.interpolation],
                             tables.EXTRAPOLATIONS[self.extrapolation],
                             float(self.time_offset), float(self.scale),
                             0.0 if n == 1 else tuple(float(i) for i in range(n)))

    def initialize(self) -> None:
        p = self._params()
        self.y = dk.data_element(self.start_time, p.elements, p)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=dk.data_step)


def _at_least_two(times: tuple[float, ...]) -> Problems:
    if len(times) < 2:
        return [("times", f"{len(times)} sample time(s); at least two are needed.",
                 "give two or more samples.")]
    return []


def _samples(comp: Component) -> dict[str, int | str]:
    """#defines of the instance: its number of samples, and the kernels' SNAP."""
    checked(comp)
    return {"N_SAMPLES": len(comp.get("times")), "SNAP": repr(dk.SNAP)}


# -- C twin (`twmr export data`: a standalone C FMU from c/data.c) --------------------------------
C = Path(__file__).parent / "c"
Data.c_twin = CTwin(C / "data.c", headers=(C / "tables.h",),
                    defines=tables.EXTRAP_CODES,
                    choices={"interpolation": Choice("INTERP_HOLD", {
                        k: int(v) for k, v in tables.INTERPOLATIONS.items()}),
                        "extrapolation": Choice("EXTRAPOLATION", {
                            k: int(v) for k, v in tables.EXTRAPOLATIONS.items()})},
                    tunable=frozenset({"time_offset", "scale"}), order=elements,
                    sizes=_samples)
