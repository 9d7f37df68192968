"""The optional parts of the install (`pip install 'twmr-cosim[EXTRA]'`) and the error that names
the extra when a part is missing: plots (matplotlib), sweeps on Dask, tuning (Optuna), the live
view (websockets), CAN drives (python-can, canopen, cantools) and ROS 2 topics (cyclonedds,
rosbags)."""
from __future__ import annotations

import importlib
from typing import Any

from twmr.core.errors import CosimError

#: the extra that installs each optional top-level module
EXTRA_OF = {"matplotlib": "plot", "dask": "cluster", "distributed": "cluster",
            "optuna": "tune", "websockets": "live", "can": "hw", "canopen": "hw",
            "cantools": "hw", "cyclonedds": "ros2", "rosbags": "ros2"}


def missing(err: ImportError, what: str) -> CosimError | None:
    """The error to raise for `err` (an import that failed while doing `what`) when the module
    is part of an extra; None when it is not one of them."""
    top = (err.name or "").partition(".")[0]
    extra = EXTRA_OF.get(top)
    if extra is None:
        return None
    return CosimError(f"{what} needs {top}, which is not installed. Fix: pip install "
                      f"'twmr-cosim[{extra}]' (or '.[{extra}]' in a checkout; '[test]' "
                      f"installs every extra).")


def require(module: str, what: str) -> Any:
    """`module` imported, or a CosimError naming the extra that installs it (`what`: what the
    user asked for, e.g. 'twmr plot')."""
    try:
        return importlib.import_module(module)
    except ImportError as err:
        error = missing(err, what)
        if error is None:
            raise
        raise error from None
