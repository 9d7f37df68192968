"""Hostile scenario files through `twmr check FILE` (and `twmr run FILE --out out` where running
matters): every one either works or is refused with a clean one-paragraph error naming the
place at fault and a fix; no traceback, no hang, no memory blow-up, nothing written outside the
results folder (and nothing at all by `check`)."""
from __future__ import annotations

import io
import os
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.hostile.runner import (
    PAPER,
    assert_clean_error,
    assert_ok,
    assert_ok_or_clean_error,
    assert_writes_only_under,
    result_family,
    run_cli,
    write,
)

F = "scenario.yaml"

# Line numbers of BASE are part of the cases' expectations (`mentions`): keep it as is.
BASE = """\
description: hostile base
components:
  ref: {kind: step, parameters: {height: 1.0, time: 0.1}}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl:
    kind: gain
    parameters: {k: 2.0}
  plant: {kind: integrator}
connections:
  - ref.y -> err.u1
  - plant.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment:
  start: 0.0
  stop: 1.0
  step: 0.01
  algorithm: gauss_seidel
record:
  signals: ["plant.*", ctrl.y]
  decimation: 2
"""


def sub(*pairs: str, base: str = BASE) -> str:
    """BASE with each (old, new) pair replaced once; a pair that does not match is a test bug."""
    text = base
    for old, new in zip(pairs[::2], pairs[1::2], strict=False):
        assert old in text, f"test bug: {old!r} not in the base scenario"
        text = text.replace(old, new, 1)
    return text


def conn(line: str) -> str:
    """BASE with its 4th connection replaced by `line` (at line 13)."""
    return sub("  - ctrl.y -> plant.u\n", f"  - {line}\n")


def chain(n: int) -> str:
    comps = ["  src: {kind: step, parameters: {height: 1.0, time: 0.0}}"]
    comps += [f"  g{i}: {{kind: gain, parameters: {{k: 1.0}}}}" for i in range(n)]
    conns = ["  - src.y -> g0.u"] + [f"  - g{i}.y -> g{i + 1}.u" for i in range(n - 1)]
    return ("components:\n" + "\n".join(comps) + "\nconnections:\n" + "\n".join(conns) +
            f"\nexperiment: {{stop: 0.1, step: 0.01}}\nrecord: {{signals: [g{n - 1}.y]}}\n")


BILLION_LAUGHS = """\
a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]
b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]
c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]
d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]
e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]
f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e]
g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f]
h: &h [*g,*g,*g,*g,*g,*g,*g,*g,*g]
i: &i [*h,*h,*h,*h,*h,*h,*h,*h,*h]
"""

ANCHORS = """\
description: anchors and aliases used normally
components:
  ref: {kind: step, parameters: &p {height: 1.0, time: 0.1}}
  ref2: {kind: step, parameters: *p}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl: {kind: gain, parameters: {k: 2.0}}
  plant: {kind: integrator}
connections:
  - ref.y -> err.u1
  - plant.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment: &exp {start: 0.0, stop: 1.0, step: 0.01}
record: {signals: &sig ["plant.*"]}
"""

MERGE_KEY = sub("  ctrl:\n    kind: gain\n    parameters: {k: 2.0}\n",
                "  ctrl:\n    <<: {kind: gain}\n    parameters: {k: 2.0}\n")

PLANT_R_NAN = PAPER.read_text().replace("parameters: {scale: 1.25}",
                                        "parameters: {scale: 1.25, r: .nan}", 1) \
    .replace("stop: 30.0", "stop: 0.02", 1)
assert ".nan" in PLANT_R_NAN and "stop: 0.02" in PLANT_R_NAN


def fmu_scenario(path: str) -> str:
    return ("components:\n  ref: {kind: step}\n  m:\n    kind: fmu\n"
            f"    parameters: {{path: {path}}}\n"
            "experiment: {stop: 0.1, step: 0.01}\n")


def _zip(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


# -- special files -------------------------------------------------------------------------------
def make_dir(cwd: Path) -> str:
    (cwd / F).mkdir()
    return F


def make_fifo(cwd: Path) -> str:
    os.mkfifo(cwd / F)
    return F


def make_devzero(cwd: Path) -> str:
    return "/dev/zero"


def make_missing(cwd: Path) -> str:
    return "no_such_scenario.yaml"


def make_unreadable(cwd: Path) -> str:
    p = write(cwd, F, BASE)
    p.chmod(0)
    try:
        p.read_text()
    except PermissionError:
        return F
    pytest.skip("running as root: a mode-000 file is still readable")


def make_symlink_loop(cwd: Path) -> str:
    os.symlink(F, cwd / F)
    return F


def fmu_files(content: bytes | None, name: str = "model.fmu") -> Callable[[Path], str]:
    def make(cwd: Path) -> str:
        if content is not None:
            write(cwd, name, content)
        write(cwd, F, fmu_scenario(name))
        return F
    return make


def make_50mb(cwd: Path) -> str:
    with open(cwd / F, "w") as f:
        f.write(BASE)
        line = "# " + "x" * 98 + "\n"
        for _ in range(50):
            f.write(line * 10_000)
    return F


# -- the cases -------------------------------------------------------------------------------------
@dataclass
class Case:
    content: str | bytes | None = None         # the file's content (F in the temp folder)
    expect: str = "error"                      # check: "error" | "ok" | "either"
    run: str | None = None                     # run too: "error" | "ok" | "either"
    mentions: tuple[str, ...] = (F,)
    sets: tuple[str, ...] = ()
    make: Callable[[Path], str] | None = None  # builds a special file, returns the argument
    timeout: float = 30
    fix: bool = True
    slow: bool = False
    quick: float | None = None                 # must answer within this many seconds
    extra: Callable[[Path], None] | None = field(default=None)  # more checks on the folder


def no_pwned(cwd: Path) -> None:
    assert not (cwd / "PWNED").exists(), "a YAML tag executed code"


CASES: dict[str, Case] = {
    # YAML syntax
    "syntax-unclosed-flow-mapping": Case(sub("{kind: integrator}", "{kind: integrator"),
                                         mentions=(F,)),
    "syntax-unclosed-flow-sequence": Case(sub('signals: ["plant.*", ctrl.y]',
                                              'signals: ["plant.*", ctrl.y')),
    "syntax-bad-indentation": Case(sub("  stop: 1.0\n", "   stop: 1.0\n"), mentions=(F,)),
    "syntax-dedented-key": Case(sub("    parameters: {k: 2.0}\n", "   parameters: {k: 2.0}\n"),
                                mentions=(F,)),
    "syntax-unclosed-double-quote": Case(sub("description: hostile base",
                                             'description: "hostile base'), mentions=(F,)),
    "syntax-unclosed-single-quote": Case(sub('"plant.*"', "'plant.*"), mentions=(F,)),
    "syntax-mapping-value-not-allowed": Case(sub("kind: gain", "kind: gain: x"),
                                             mentions=(f"{F}:6",)),
    "syntax-tab-indentation": Case(sub("  stop: 1.0\n", "\tstop: 1.0\n"), mentions=(F,)),
    "syntax-tabs-mixed-with-spaces": Case(sub("    kind: gain\n", "  \t  kind: gain\n"),
                                          mentions=(F,)),
    "syntax-undefined-alias": Case(sub("k: 2.0", "k: *nowhere"), mentions=(f"{F}:7",)),
    "syntax-python-tag-executes-nothing": Case(
        sub("k: 2.0", 'k: !!python/object/apply:os.system ["touch PWNED"]'),
        mentions=(f"{F}:7",), extra=no_pwned),
    "syntax-unknown-local-tag": Case(sub("k: 2.0", "k: !mytag 2.0"), mentions=(F,)),
    "syntax-two-documents": Case(BASE + "---\n" + BASE, mentions=(F,)),
    "syntax-nul-byte": Case(sub("hostile base", "hostile\x00base"), mentions=(f"{F}:1",)),
    "syntax-control-character": Case(sub("hostile base", "hostile\x07base"),
                                     mentions=(f"{F}:1",)),
    "syntax-stray-closing-bracket": Case(sub("{k: 2.0}", "{k: 2.0}}"), mentions=(F,)),
    "syntax-list-item-inside-mapping": Case(sub("  start: 0.0\n", "  start: 0.0\n  - 3\n"),
                                            mentions=(F,)),
    # encodings and (nearly) empty files
    "encoding-latin1-bytes": Case(sub("hostile base", "caf\u00e9").encode("latin-1"),
                                  mentions=(F,)),
    "encoding-utf16-with-bom": Case(BASE.encode("utf-16"), mentions=(F,)),
    "encoding-utf8-bom-works": Case(b"\xef\xbb\xbf" + BASE.encode(), expect="ok", run="ok"),
    "empty-file": Case("", mentions=(F,)),
    "only-a-comment": Case("# nothing here\n", mentions=(F,)),
    "only-blank-lines": Case("\n\n   \n\n", mentions=(F,)),
    "top-level-list": Case("- components\n- experiment\n", mentions=(F,)),
    "top-level-scalar-number": Case("42\n", mentions=(F,)),
    "top-level-scalar-string": Case("hello world\n", mentions=(F,)),
    # null where a value is expected
    "null-kind": Case(sub("kind: gain", "kind: null"), mentions=(f"{F}:6", "ctrl")),
    "null-parameters": Case(sub("parameters: {k: 2.0}", "parameters: null"),
                            expect="either", mentions=(f"{F}:7", "ctrl")),
    "null-parameter-value": Case(sub("k: 2.0", "k: null"), mentions=(f"{F}:7", "ctrl", "k")),
    "null-component-spec": Case(sub("plant: {kind: integrator}", "plant: null"),
                                mentions=(f"{F}:8", "plant")),
    "null-components": Case("components: null\nexperiment: {stop: 1.0, step: 0.01}\n",
                            mentions=(f"{F}:1", "components")),
    "null-connection-item": Case(conn("null"), mentions=(f"{F}:13", "connections")),
    "null-connections": Case(sub("connections:\n  - ref.y -> err.u1\n  - plant.y -> err.u2\n"
                                 "  - err.y -> ctrl.u\n  - ctrl.y -> plant.u\n",
                                 "connections: null\n"),
                             mentions=(f"{F}:9", "connections")),
    "null-experiment": Case(sub("experiment:\n  start: 0.0\n  stop: 1.0\n  step: 0.01\n"
                                "  algorithm: gauss_seidel\n", "experiment: null\n"),
                            mentions=(f"{F}:14", "experiment")),
    "null-stop": Case(sub("stop: 1.0", "stop: null"), mentions=(f"{F}:16", "stop")),
    "null-step": Case(sub("step: 0.01", "step:"), mentions=(f"{F}:17", "step")),
    "null-record-signals": Case(sub('signals: ["plant.*", ctrl.y]', "signals: null"),
                                expect="either", mentions=(f"{F}:20", "signals")),
    "null-open-item": Case(sub("  - ctrl.y -> plant.u\n", "  - ctrl.y -> plant.u\nopen: [null]\n"),
                           mentions=(f"{F}:14", "open")),
    # wrong types
    "type-stop-string": Case(sub("stop: 1.0", "stop: ten"), mentions=(f"{F}:16", "stop")),
    "type-stop-number-with-unit": Case(sub("stop: 1.0", 'stop: "1 s"'),
                                       expect="either", mentions=(f"{F}:16", "stop")),
    "type-step-list": Case(sub("step: 0.01", "step: [1]"), mentions=(f"{F}:17", "step")),
    "type-algorithm-number": Case(sub("algorithm: gauss_seidel", "algorithm: 3"),
                                  mentions=(f"{F}:18", "algorithm")),
    "type-algorithm-unknown": Case(sub("algorithm: gauss_seidel", "algorithm: rk45"),
                                   mentions=(f"{F}:18", "algorithm")),
    "type-realtime-string": Case(sub("algorithm: gauss_seidel", "realtime: maybe"),
                                 mentions=(f"{F}:18", "realtime")),
    "type-decimation-negative": Case(sub("decimation: 2", "decimation: -1"),
                                     mentions=(f"{F}:21", "decimation")),
    "type-decimation-zero": Case(sub("decimation: 2", "decimation: 0"),
                                 mentions=(f"{F}:21", "decimation")),
    "type-decimation-fraction": Case(sub("decimation: 2", "decimation: 1.5"),
                                     mentions=(f"{F}:21", "decimation")),
    "type-step-multiple-zero": Case(sub("    kind: gain\n",
                                        "    kind: gain\n    step_multiple: 0\n"),
                                    mentions=(f"{F}:7", "ctrl", "step_multiple")),
    "type-step-multiple-negative": Case(sub("    kind: gain\n",
                                            "    kind: gain\n    step_multiple: -2\n"),
                                        mentions=(f"{F}:7", "ctrl", "step_multiple")),
    "type-step-multiple-fraction": Case(sub("    kind: gain\n",
                                            "    kind: gain\n    step_multiple: 2.5\n"),
                                        mentions=(f"{F}:7", "ctrl", "step_multiple")),
    "type-parameter-text": Case(sub("k: 2.0", "k: abc"), mentions=(f"{F}:7", "ctrl", "k")),
    "type-parameter-list-for-scalar": Case(sub("k: 2.0", "k: [1, 2]"),
                                           mentions=(f"{F}:7", "ctrl", "k")),
    "type-parameter-mapping": Case(sub("k: 2.0", "k: {a: 1}"), mentions=(f"{F}:7", "ctrl", "k")),
    "type-parameter-wrong-unit": Case(sub("time: 0.1", 'time: "3 kg"'),
                                      mentions=(f"{F}:3", "ref", "time")),
    "type-kind-list": Case(sub("kind: gain", "kind: [gain]"), mentions=(f"{F}:6", "ctrl")),
    "type-components-list": Case("components: [a, b]\nexperiment: {stop: 1.0, step: 0.01}\n",
                                 mentions=(f"{F}:1", "components")),
    "type-component-name-with-dash": Case(sub("  plant: {kind: integrator}", "  plant: {kind: "
                                              "integrator}\n  my-comp: {kind: step}"),
                                          mentions=(F, "my-comp")),
    "type-integer-key": Case(sub("  plant: {kind: integrator}",
                                 "  plant: {kind: integrator}\n  7: {kind: step}"),
                             mentions=(F, "7")),
    # NaN and infinities
    "nan-stop": Case(sub("stop: 1.0", "stop: .nan"), run="error", mentions=(f"{F}:16", "stop")),
    "inf-stop": Case(sub("stop: 1.0", "stop: .inf"), run="error", mentions=(f"{F}:16", "stop")),
    "nan-step": Case(sub("step: 0.01", "step: .nan"), run="error", mentions=(f"{F}:17", "step")),
    "inf-step": Case(sub("step: 0.01", "step: .inf"), run="error", mentions=(f"{F}:17", "step")),
    "nan-start": Case(sub("start: 0.0", "start: .nan"), run="error", mentions=(F, "start")),
    "inf-start": Case(sub("start: 0.0", "start: .inf"), run="error", mentions=(F, "start")),
    "minus-inf-start": Case(sub("start: 0.0", "start: -.inf"), run="error",
                            mentions=(F, "start")),
    "nan-parameter": Case(sub("k: 2.0", "k: .nan"), run="error", mentions=(f"{F}:7", "ctrl", "k")),
    "inf-parameter": Case(sub("k: 2.0", "k: .inf"), expect="either", run="error",
                          mentions=("ctrl",)),
    "nan-plant-wheel-radius": Case(PLANT_R_NAN, run="error", mentions=(F, "plant", "r")),
    "nan-initial-value": Case(sub("plant: {kind: integrator}",
                                  "plant: {kind: integrator, parameters: {x0: .nan}}"),
                              run="error", mentions=(f"{F}:8", "plant", "x0")),
    # the time grid
    "step-larger-than-stop": Case(sub("step: 0.01", "step: 2.0"), run="error",
                                  mentions=(F, "step")),
    "step-zero": Case(sub("step: 0.01", "step: 0"), mentions=(f"{F}:17", "step")),
    "step-negative": Case(sub("step: 0.01", "step: -0.01"), mentions=(f"{F}:17", "step")),
    "stop-before-start": Case(sub("start: 0.0", "start: 2.0"), mentions=(F, "stop")),
    "1e300-steps-huge-stop": Case(sub("stop: 1.0", "stop: 1.0e+300", "step: 0.01", "step: 1.0"),
                                  expect="either", run="error", mentions=(F,), timeout=30,
                                  slow=True),
    "1e300-steps-tiny-step-check": Case(sub("step: 0.01", "step: 1.0e-300"), expect="either",
                                        mentions=(F,)),
    "negative-start-works": Case(sub("start: 0.0", "start: -1.0"), expect="ok", run="ok"),
    # size and shape
    "chain-of-4000-gains": Case(chain(4000), expect="either", run="either", timeout=60,
                                slow=True),
    "nested-5000-lists-as-parameter": Case(sub("k: 2.0", "k: " + "[" * 5000 + "]" * 5000),
                                           mentions=(F,)),
    "nested-5000-mappings": Case(sub("description: hostile base",
                                     "description: hostile base\nx: " + "{a: " * 5000 +
                                     "1" + "}" * 5000), mentions=(F,)),
    "alias-bomb-billion-laughs": Case(BILLION_LAUGHS + BASE.replace("description", "notes", 1),
                                      mentions=(F,), timeout=10, quick=5.0, slow=True),
    "anchors-and-aliases-work": Case(ANCHORS, expect="ok", run="ok"),
    "merge-key-works": Case(MERGE_KEY, expect="ok"),
    "file-of-50-MB": Case(make=make_50mb, expect="either", mentions=(F,), timeout=90, slow=True),
    # unknown and duplicate keys
    "unknown-key-top": Case(sub("record:", "recrod: {}\nrecord:"),
                            mentions=(f"{F}:19", "recrod")),
    "unknown-key-component": Case(sub("    kind: gain\n", "    kind: gain\n    paramters: {}\n"),
                                  mentions=(f"{F}:7", "ctrl", "paramters")),
    "unknown-key-experiment": Case(sub("  stop: 1.0\n", "  stop: 1.0\n  stpo: 2.0\n"),
                                   mentions=(f"{F}:17", "stpo")),
    "unknown-key-record": Case(sub("decimation: 2", "decimation: 2\n  every: 3"),
                               mentions=(f"{F}:22", "every")),
    "unknown-parameter": Case(sub("k: 2.0", "kk: 2.0"), mentions=(f"{F}:7", "ctrl", "kk")),
    "unknown-keys-at-every-level": Case(
        sub("description: hostile base", "description: hostile base\nfoo: 1",
            "    kind: gain\n", "    kind: gain\n    bar: 2\n",
            "  stop: 1.0\n", "  stop: 1.0\n  baz: 3\n",
            "decimation: 2", "decimation: 2\n  qux: 4"),
        mentions=("foo", "bar", "baz", "qux")),
    "duplicate-top-key": Case(BASE + "experiment: {stop: 2.0, step: 0.01}\n",
                              mentions=(f"{F}:22", "experiment")),
    "duplicate-component": Case(sub("  plant: {kind: integrator}",
                                    "  plant: {kind: integrator}\n  ctrl: {kind: gain}"),
                                mentions=(f"{F}:9", "ctrl")),
    "duplicate-key-in-flow-mapping": Case(sub("{k: 2.0}", "{k: 2.0, k: 3.0}"),
                                          mentions=(f"{F}:7", "k")),
    # connections
    "conn-missing-destination": Case(conn("ctrl.y->"), mentions=(f"{F}:13", "ctrl.y->")),
    "conn-missing-source": Case(conn("->plant.u"), mentions=(f"{F}:13", "->plant.u")),
    "conn-two-arrows": Case(conn("ctrl.y -> plant.u -> err.u2"), mentions=(f"{F}:13",)),
    "conn-zero-index": Case(conn("ctrl.y[0] -> plant.u"), mentions=(f"{F}:13", "ctrl")),
    "conn-reversed-range": Case(conn("ctrl.y[3:1] -> plant.u"), mentions=(f"{F}:13", "ctrl")),
    "conn-space-after-dot": Case(conn("ctrl. y -> plant.u"), mentions=(f"{F}:13",)),
    "conn-no-arrow": Case(conn("ctrl.y plant.u"), mentions=(f"{F}:13",)),
    "conn-mapping-item": Case(conn("{ctrl.y: plant.u}"), mentions=(f"{F}:13",)),
    "conn-self-loop-feedthrough": Case(sub("  - plant.y -> err.u2\n", "  - err.y -> err.u2\n"),
                                       mentions=(f"{F}:11", "err")),
    "conn-self-loop-integrator-works": Case(conn("plant.y -> plant.u"), expect="ok"),
    "conn-output-to-output": Case(conn("ctrl.y -> plant.y"), mentions=(f"{F}:13", "plant")),
    "conn-input-to-input": Case(conn("ctrl.u -> plant.u"), mentions=(f"{F}:13", "ctrl")),
    "conn-unknown-component": Case(conn("nope.y -> plant.u"), mentions=(f"{F}:13", "nope")),
    "conn-unknown-port": Case(conn("ctrl.yy -> plant.u"), mentions=(f"{F}:13", "yy")),
    "conn-input-driven-twice": Case(conn("ref.y -> err.u1").replace(
        "  - ctrl.y -> plant.u\n", ""), mentions=(F, "err.u1")),
    "conn-index-past-width": Case(conn("ctrl.y[2] -> plant.u"), mentions=(f"{F}:13", "ctrl")),
    "input-not-connected": Case(sub("  - ctrl.y -> plant.u\n", ""), mentions=(F, "plant.u")),
    # kinds
    "kind-unknown-typo": Case(sub("kind: gain", "kind: gian"), mentions=(f"{F}:6", "gian")),
    "kind-python-path": Case(sub("kind: gain", "kind: 'os:system'"), mentions=(f"{F}:6",
                                                                             "os:system")),
    # a class path is a kind of its own (docs/components.md): a Component class works...
    "kind-python-class-path": Case(sub("kind: gain", "kind: 'twmr.blocks:Gain'"), expect="ok",
                                   run="ok"),
    # ...a file that is not there, or a module that is not a block's, is a located error
    "kind-python-file-missing": Case(sub("kind: gain", "kind: 'nope.py:Gain'"),
                                     mentions=(f"{F}:6", "nope.py", "ctrl")),
    "kind-python-module-not-a-class": Case(sub("kind: gain", "kind: 'math:pi'"),
                                           mentions=(f"{F}:6", "math:pi", "ctrl", "--trust-code")),
    "kind-empty-string": Case(sub("kind: gain", "kind: ''"), mentions=(f"{F}:6", "ctrl")),
    # record and open
    "record-matches-nothing": Case(sub('"plant.*"', '"nothing.*"'),
                                   mentions=(f"{F}:20", "nothing.*")),
    "record-a-parameter": Case(sub("ctrl.y]", "ctrl.k]"), mentions=(f"{F}:20", "ctrl.k")),
    "record-not-a-list": Case(sub('signals: ["plant.*", ctrl.y]', "signals: plant.y"),
                              mentions=(f"{F}:20", "signals")),
    "open-an-output": Case(sub("record:", "open: [ctrl.y]\nrecord:"),
                           mentions=(f"{F}:19", "ctrl.y")),
    "open-unknown-component": Case(sub("record:", "open: [nope.u]\nrecord:"),
                                   mentions=(f"{F}:19", "nope.u")),
    "open-not-a-list": Case(sub("record:", "open: plant.u\nrecord:"),
                            mentions=(f"{F}:19", "open")),
    # the path itself
    "path-is-a-directory": Case(make=make_dir, run="error"),
    "path-is-a-fifo": Case(make=make_fifo, run="error", timeout=10, slow=True),
    "path-is-dev-zero": Case(make=make_devzero, mentions=("/dev/zero",), timeout=30, slow=True),
    "path-does-not-exist": Case(make=make_missing, mentions=("no_such_scenario.yaml",)),
    "path-not-readable": Case(make=make_unreadable),
    "path-symlink-loop": Case(make=make_symlink_loop),
    # FMUs
    "fmu-path-missing": Case(make=fmu_files(None), mentions=(F, "model.fmu")),
    "fmu-text-file-renamed": Case(make=fmu_files(b"this is not a zip\n"),
                                  mentions=(F, "model.fmu")),
    "fmu-zip-without-model-description": Case(make=fmu_files(_zip({"readme.txt": b"hi"})),
                                              mentions=(F, "model.fmu")),
    "fmu-zip-with-garbage-model-description": Case(
        make=fmu_files(_zip({"modelDescription.xml": b"<fmiModelDescription"})),
        mentions=(F, "model.fmu")),
    "fmu-path-is-a-directory": Case(make=lambda cwd: (os.mkdir(cwd / "model.fmu"),
                                                      fmu_files(None)(cwd))[1],
                                    mentions=(F, "model.fmu")),
    # --set overrides
    "set-no-equals": Case(BASE, sets=("x",), mentions=("--set",)),
    "set-empty-name": Case(BASE, sets=("=1",), mentions=("--set",)),
    "set-three-part-name": Case(BASE, sets=("a.b.c=1",), mentions=("--set", "a.b.c")),
    "set-negative-stop": Case(BASE, sets=("experiment.stop=-1",),
                              mentions=("--set", "experiment.stop=-1")),
    "set-unknown-experiment-key": Case(BASE, sets=("experiment.nope=1",),
                                       mentions=("--set", "nope")),
    "set-list-for-scalar": Case(BASE, sets=("ctrl.k=[1,2]",), mentions=("--set", "ctrl.k")),
    "set-unknown-component": Case(BASE, sets=("nope.k=1",), mentions=("--set", "nope")),
    "set-unknown-parameter": Case(BASE, sets=("ctrl.kk=1",), mentions=("--set", "kk")),
    "set-empty-value": Case(BASE, sets=("ctrl.k=",), mentions=("--set", "ctrl.k")),
    "set-unclosed-list": Case(BASE, sets=("ctrl.k=[1,",), mentions=("--set", "ctrl.k")),
    "set-step-multiple-zero": Case(BASE, sets=("ctrl.step_multiple=0",),
                                   mentions=("--set", "step_multiple")),
    "set-step-text": Case(BASE, sets=("experiment.step=abc",), mentions=("--set", "step")),
    "set-python-tag": Case(BASE, sets=('ctrl.k=!!python/object/apply:os.system ["touch PWNED"]',),
                           mentions=("--set",), extra=no_pwned),
    "set-whole-experiment": Case(BASE, sets=("experiment=1",), mentions=("--set",)),
}


def _params():
    for name, case in CASES.items():
        marks = [pytest.mark.slow] if case.slow else []
        yield pytest.param(case, id=name, marks=marks)


@pytest.mark.parametrize("case", list(_params()))
def test_hostile_scenario_file(case: Case, tmp_path: Path) -> None:
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    if case.make is not None:
        arg = case.make(cwd)
    else:
        assert case.content is not None
        write(cwd, F, case.content)
        arg = F
    sets = [x for s in case.sets for x in ("--set", s)]

    # checking is instant: a check gets at most 10 s unless the case says more
    checked = run_cli(["check", arg, *sets], cwd, timeout=case.timeout if case.slow else
                      min(case.timeout, 10), watched=[tmp_path])
    if case.quick is not None:
        assert checked.elapsed < case.quick, f"took {checked.elapsed:.1f} s (> {case.quick} s)"
    _expect(case, case.expect, checked)
    assert_writes_only_under(checked, [])
    if case.extra:
        case.extra(cwd)

    if case.run is not None:
        ran = run_cli(["run", arg, *sets, "--out", "out"], cwd, timeout=case.timeout,
                      watched=[tmp_path])
        _expect(case, case.run, ran)
        assert_writes_only_under(ran, result_family(cwd / "out"))
        if ran.returncode == 0:
            assert (cwd / "out" / "result.arrows").is_file(), ran.describe()


def _expect(case: Case, expect: str, outcome) -> None:
    if expect == "ok":
        assert_ok(outcome)
    elif expect == "error":
        assert_clean_error(outcome, fix=case.fix, mentions=case.mentions)
    else:
        assert_ok_or_clean_error(outcome, fix=case.fix, mentions=case.mentions)
