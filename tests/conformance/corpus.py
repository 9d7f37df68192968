"""Where the third-party conformance files are: `../shared/conformance/` beside the checkout
(or the folder `TWMR_CONFORMANCE` names). A test that needs one skips, saying so, when it is
absent."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(os.environ.get("TWMR_CONFORMANCE")
            or Path(__file__).resolve().parents[3] / "shared" / "conformance")


def corpus(*parts: str) -> Path:
    """The conformance file or folder `parts` (skips the test when it is absent)."""
    path = ROOT.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"third-party conformance file {path} is absent (set TWMR_CONFORMANCE to "
                    f"the folder of other tools' FMI, SSP and LS-BUS files)")
    return path
