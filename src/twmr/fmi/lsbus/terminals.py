"""Bus terminals of an FMI-LS-BUS FMU: `terminalsAndIcons/terminalsAndIcons.xml` (network
terminals and their Tx_Data/Tx_Clock/Rx_Data/Rx_Clock members), the layered standard's manifest
`extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml`, and the MIME type of the terminal's
Binary variables, checked to be CAN (`application/org.fmi-standard.fmi-ls-bus.can`) of version
1.0.0; the 1.0.0-beta versions that published FMUs still carry are accepted with a note.
"""
from __future__ import annotations

import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from twmr.core.errors import FmuError

NETWORK_TERMINAL = "org.fmi-ls-bus.network-terminal"
LS_NAME = "org.fmi-standard.fmi-ls-bus"
MANIFEST = f"extra/{LS_NAME}/fmi-ls-manifest.xml"
TERMINALS = "terminalsAndIcons/terminalsAndIcons.xml"
CAN_MIME = "application/org.fmi-standard.fmi-ls-bus.can"
VERSION = "1.0.0"
MEMBERS = ("Tx_Data", "Tx_Clock", "Rx_Data", "Rx_Clock")
_LS = "{http://fmi-standard.org/fmi-ls-manifest}"
_MIME = re.compile(r'^\s*([^;\s]+)\s*(?:;\s*version\s*=\s*"?([^";\s]*)"?)?\s*$')


@dataclass
class BusTerminal:
    """A network terminal: its name and member -> the FMU variable (port) that is it."""

    name: str
    members: dict[str, str]
    version: str = VERSION
    notes: list[str] = field(default_factory=list)

    def peer(self, member: str) -> str:
        """The member of the other side's terminal a member is wired to (Tx_Data -> Rx_Data)."""
        return member.replace("Tx_", "Rx_") if member.startswith("Tx_") else \
            member.replace("Rx_", "Tx_")


def _read(path: Path, inner: str) -> bytes | None:
    if path.is_dir():
        file = path / inner
        return file.read_bytes() if file.is_file() else None
    with zipfile.ZipFile(path) as z:
        return z.read(inner) if inner in z.namelist() else None


def _parse(raw: bytes, path: Path, inner: str, instance: str) -> etree._Element:
    try:
        return etree.fromstring(raw)
    except etree.XMLSyntaxError as err:
        raise FmuError(instance, None, f"'{path.name}': {inner} is not well-formed XML "
                       f"({err.msg}). Fix: correct the FMU's {inner} (or ask its vendor)."
                       ) from None


def bus_terminals(path: Path, instance: str) -> list[BusTerminal]:
    """The LS-BUS network terminals of the FMU at `path` (zip or folder), checked: members
    that name variables, the manifest's layered standard and version, and CAN as the MIME type
    of the Binary members. [] for an FMU without network terminals."""
    raw = _read(path, TERMINALS)
    if raw is None:
        return []
    root = _parse(raw, path, TERMINALS, instance)
    found = [t for t in root.iter("Terminal") if t.get("terminalKind") == NETWORK_TERMINAL]
    if not found:
        return []
    manifest = _read(path, MANIFEST)
    if manifest is None:
        raise FmuError(instance, None, f"'{path.name}' has LS-BUS network terminals "
                       f"({', '.join(str(t.get('name')) for t in found)}) but no {MANIFEST}. "
                       f"Fix: add the manifest of FMI-LS-BUS to the FMU (or ask its vendor).")
    betas: dict[str, list[str]] = {}  # pre-release version -> where the FMU says it
    m = _parse(manifest, path, MANIFEST, instance)
    name, version = m.get(f"{_LS}fmi-ls-name"), m.get(f"{_LS}fmi-ls-version") or ""
    if name != LS_NAME:
        raise FmuError(instance, None, f"'{path.name}': {MANIFEST} names the layered standard "
                       f"'{name}', not '{LS_NAME}'. Fix: correct the manifest.")
    _check_version(path, instance, version, "the LS-BUS manifest", betas)
    mimes = _mime_types(path)
    terminals = []
    for t in found:
        tname = str(t.get("name"))
        members = {str(v.get("memberName")): str(v.get("variableName"))
                   for v in t.findall("TerminalMemberVariable")}
        missing = [k for k in MEMBERS if k not in members]
        if missing:
            raise FmuError(instance, None, f"'{path.name}': bus terminal '{tname}' lacks "
                           f"member(s) {', '.join(missing)} (an LS-BUS network terminal has "
                           f"{', '.join(MEMBERS)}). Fix: correct its terminalsAndIcons.xml.")
        for member in ("Tx_Data", "Rx_Data"):
            var = members[member]
            if var not in mimes:
                raise FmuError(instance, None, f"'{path.name}': bus terminal '{tname}' member "
                               f"{member} names '{var}', which is no Binary variable of the "
                               f"FMU. Fix: correct its terminalsAndIcons.xml.")
            got = _MIME.match(mimes[var] or "")
            mime, mversion = (got.group(1), got.group(2) or "") if got else (mimes[var], "")
            if mime != CAN_MIME:
                raise FmuError(instance, None, f"'{path.name}': bus terminal '{tname}' "
                               f"({var}) has MIME type '{mimes[var]}', not CAN ('{CAN_MIME}'); "
                               f"this importer runs CAN bus terminals only. Fix: use a CAN "
                               f"network FMU, or leave this FMU's bus unconnected.")
            _check_version(path, instance, mversion, f"the MIME type of {var}", betas)
        terminals.append(BusTerminal(tname, members, version, []))
    notes = [f"'{path.name}' says FMI-LS-BUS {v}, a pre-release of {VERSION} ({', '.join(w)}); "
             f"its operations are read in the {VERSION} layout." for v, w in betas.items()]
    for terminal in terminals:
        terminal.notes.extend(notes)
    return terminals


def max_sizes(path: Path) -> dict[str, int]:
    """Binary variable name -> its maxSize [bytes], for those of the FMU at `path` that give
    one (what an importer may set at once)."""
    raw = _read(path, "modelDescription.xml") or b"<x/>"
    return {str(v.get("name")): int(str(v.get("maxSize"))) for v in etree.fromstring(raw).iter(
        "Binary") if str(v.get("maxSize", "")).isdigit()}


def is_bus_simulation(path: Path) -> bool:
    """Whether the FMU at `path` says it is an LS-BUS bus simulation (its manifest's
    `isBusSimulationFMU`)."""
    raw = _read(path, MANIFEST)
    if raw is None:
        return False
    root = etree.fromstring(raw)
    return "true" in (root.get("isBusSimulationFMU"), root.get(f"{_LS}isBusSimulationFMU"))


def _mime_types(path: Path) -> dict[str, str | None]:
    """Binary variable name -> its mimeType attribute (fmpy does not keep it)."""
    raw = _read(path, "modelDescription.xml") or b"<x/>"
    root = etree.fromstring(raw)
    return {str(v.get("name")): v.get("mimeType") for v in root.iter("Binary")}


def _check_version(path: Path, instance: str, version: str, what: str,
                   betas: dict[str, list[str]]) -> None:
    """`what` of the FMU says FMI-LS-BUS `version`: noted in `betas` when a pre-release of the
    version read, FmuError when another version."""
    if version == VERSION:
        return
    if version.startswith(f"{VERSION}-beta"):
        betas.setdefault(version, []).append(what)
        return
    raise FmuError(instance, None, f"'{path.name}': {what} says FMI-LS-BUS version "
                   f"'{version}'; this importer knows {VERSION} (and its 1.0.0-beta "
                   f"pre-releases). Fix: use an FMU of FMI-LS-BUS {VERSION}.")
