"""`unguarded_call`: a top-level call of a running script outside `if __name__ == "__main__":`
is found at its line, one inside is not, and a script changed on disk since it started is not
judged by its new lines (they would name other statements)."""
from __future__ import annotations

import subprocess
import sys

SCRIPT = """\
import pathlib
from twmr.sweeps.main_guard import unguarded_call
here = pathlib.Path(__file__)
print(unguarded_call())
if __name__ == "__main__":
    print(unguarded_call())
    here.write_text("\\n" * 10 + here.read_text())
    print(unguarded_call())
"""


def test_a_call_is_found_outside_the_guard_only_while_the_script_is_as_it_started(tmp_path
                                                                                  ) -> None:
    script = tmp_path / "study.py"
    script.write_text(SCRIPT, encoding="utf-8")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    outside, inside, changed = done.stdout.splitlines()
    assert outside == repr((str(script), 4))
    assert inside == "None"
    assert changed == "None"  # line 8 of the file as it is now is outside the guard
