"""Property test: mutated scenario files either load or fail with a CosimError, never otherwise."""
from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twmr.core import CosimError
from twmr.scenario import loads

GOOD = (Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml").read_text()
LINES = GOOD.splitlines(keepends=True)
TOKENS = ["kind", "gain", "->", ":", "-", "[", "]", "{", "}", "'", '"', "\t", "  ", "\n", "1e9",
          "-1", "0", "null", "true", "plant.y", "ctrl.u", "[1:2]", "[0]", "experiment", "record",
          "decimation: 0", "step: -1", "stop: x", "open: [a.b]", "&a", "*a", "!!python/object", "é"]


@st.composite
def mutated(draw: st.DrawFn) -> str:
    lines = list(LINES)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["delete_line", "duplicate_line", "swap_lines", "insert",
                                   "delete_chars", "replace_number"]))
        i = draw(st.integers(0, len(lines) - 1))
        if op == "delete_line" and len(lines) > 1:
            del lines[i]
        elif op == "duplicate_line":
            lines.insert(i, lines[i])
        elif op == "swap_lines":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "insert":
            pos = draw(st.integers(0, len(lines[i])))
            tok = draw(st.sampled_from(TOKENS) | st.text(max_size=3))
            lines[i] = lines[i][:pos] + tok + lines[i][pos:]
        elif op == "delete_chars":
            pos = draw(st.integers(0, len(lines[i])))
            lines[i] = lines[i][:pos] + lines[i][pos + draw(st.integers(1, 6)):]
        else:
            for num in ("1.0", "2.0", "0.01", "0.1", "-1.0", "2"):
                if num in lines[i]:
                    new = draw(st.sampled_from(["0", "-5", "1e300", "nan", "'x'", "[1, 2]", "{}"]))
                    lines[i] = lines[i].replace(num, new, 1)
                    break
    return "".join(lines)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_scenarios_fail_only_with_cosim_errors(text: str) -> None:
    try:
        loads(text, source="fuzz.yaml")
    except CosimError as err:
        text = str(err)
        assert text.startswith("fuzz.yaml"), text  # every problem is located in the file
        # the loader's safety net turns internal bugs into a ScenarioError; none may reach it
        assert "cannot build the scenario" not in text, text
