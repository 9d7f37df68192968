"""Package discovery and package data, computed from the tree so the wheel cannot drift from it.

Four source roots form one ``twmr`` package: ``src/twmr`` (the engine), ``components`` (the
paper's blocks, ``twmr.components``), ``hw`` (drives and buses, ``twmr.hw``) and ``ros2`` (ROS 2
topics over DDS, ``twmr.ros2``). Every folder with
an ``__init__.py`` under them is a package; every other file under a package's folder (C sources
and headers, schemas, web assets, drive descriptions) ships with it as package data.
"""

from __future__ import annotations

import os

from setuptools import setup

ROOTS = {"twmr": "src/twmr", "twmr.components": "components", "twmr.hw": "hw",
         "twmr.ros2": "ros2"}
SKIPPED_DIRS = {"__pycache__"}
SKIPPED_SUFFIXES = (".py", ".pyc", ".pyo", ".so")


def _packages(name: str, folder: str) -> dict[str, str]:
    """Each package under ``folder`` (dotted name -> folder), ``name`` being the folder's own."""
    found = {}
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if d not in SKIPPED_DIRS and not d.startswith("."))
        if "__init__.py" in files:
            rel = os.path.relpath(here, folder)
            found[name if rel == "." else f"{name}.{rel.replace(os.sep, '.')}"] = here
    return found


def _data(folder: str, packages: set[str]) -> list[str]:
    """Files under ``folder`` that are not Python modules and not inside a sub-package."""
    data = []
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(
            d for d in dirs
            if d not in SKIPPED_DIRS and not d.startswith(".")
            and os.path.realpath(os.path.join(here, d)) not in packages
        )
        for f in sorted(files):
            if not f.endswith(SKIPPED_SUFFIXES) and not f.startswith("."):
                data.append(os.path.relpath(os.path.join(here, f), folder))
    return data


def main() -> None:
    """Call setup with every package and its data."""
    found: dict[str, str] = {}
    for name, folder in ROOTS.items():
        found.update(_packages(name, folder))
    folders = {os.path.realpath(f) for f in found.values()}
    package_data = {}
    for name, folder in found.items():
        data = _data(folder, folders - {os.path.realpath(folder)})
        if data:
            package_data[name] = data
    setup(packages=sorted(found), package_dir=ROOTS, package_data=package_data)


main()
