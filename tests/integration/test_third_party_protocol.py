"""A CAN drive protocol from another package, added as one module and one entry point
(`echo = echo_protocol:EchoLink` in the group `twmr.can_protocols` of a distribution on the import
path): its own options (`scale`) become parameters of the `can_drive` block that names it, are
checked by the scenario builder (an option of another protocol is named as such), reach its link
and its emulator through `DriveSpec.options`, and `twmr replay --protocol echo -o scale=...`
decodes its frame log. The shipped protocols and the block are untouched."""
from __future__ import annotations

import csv
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr import registry
from twmr.core.errors import CosimError

MODULE = '''
import struct
import threading
import time
from dataclasses import dataclass

import can

from twmr.hw.link import Link, option

TORQUE, SPEED = 0x100, 0x200
_F = struct.Struct("<f4x")


@dataclass(frozen=True)
class EchoOptions:
    scale: float = option(1.0, unit="1", min=1e-6, description="wire units per N.m")


class EchoEmulator:
    """Drives that answer each torque frame with a speed frame: speed = torque (wire units)."""

    def __init__(self, nodes, options, scale):
        self.axes = {n: 0.0 for n in nodes}
        self.scale = scale
        self.bus = can.Bus(**options)
        self.notifier = can.Notifier(self.bus, [self._on], timeout=0.01)

    def _on(self, msg):
        node = msg.arbitration_id - TORQUE
        if node in self.axes:
            wire = _F.unpack(bytes(msg.data))[0]
            self.axes[node] = wire / self.scale
            self.bus.send(can.Message(arbitration_id=SPEED + node, data=_F.pack(wire),
                                      is_extended_id=False))

    def set_load_speeds(self, speeds):
        pass

    def applied(self):
        return dict(self.axes)

    def close(self):
        self.notifier.stop()
        self.bus.shutdown()


class EchoLink(Link):
    node_range = range(0, 16)
    default_nodes = (0, 1)
    Options = EchoOptions

    def __init__(self, spec, options, log=None):
        self.spec, self.scale = spec, spec.options.scale
        self.fault, self.fault_at, self.rtt_ns = None, float("nan"), []
        self.fb = {n: (0.0, 0.0, time.monotonic()) for n in spec.nodes}
        self.fresh = threading.Event()
        self.log = log
        self.bus = can.Bus(**options)
        self.notifier = can.Notifier(self.bus, [self._on] + ([log.received] if log else []),
                                     timeout=0.01)

    @classmethod
    def check(cls, spec):
        return []

    @classmethod
    def decode(cls, msg, spec):
        node, wire = msg.arbitration_id & 0xFF, _F.unpack(bytes(msg.data))[0]
        what = "torque_command" if msg.arbitration_id & 0xF00 == TORQUE else "speed"
        return [(node, what, wire / spec.options.scale)]

    @classmethod
    def emulate(cls, spec, options):
        return EchoEmulator(spec.nodes, options, spec.options.scale), spec

    def _on(self, msg):
        node = msg.arbitration_id - SPEED
        if node in self.fb:
            speed = _F.unpack(bytes(msg.data))[0] / self.scale
            self.fb[node] = (0.0, speed, time.monotonic())
            self.fresh.set()

    def start(self, timeout):
        pass

    def command(self, torques):
        self.fresh.clear()
        for node, tau in zip(self.spec.nodes, torques):
            msg = can.Message(arbitration_id=TORQUE + node, data=_F.pack(tau * self.scale),
                              is_extended_id=False)
            self.bus.send(msg)
            if self.log:
                self.log.sent(msg)
        return tuple(torques)

    def wait_feedback(self, timeout):
        return self.fresh.wait(timeout)

    def feedback(self):
        return [self.fb[n] for n in self.spec.nodes]

    def heartbeats(self):
        return {n: time.monotonic() for n in self.spec.nodes}

    def protection(self):
        return {n: (False, "a toy") for n in self.spec.nodes}

    def disable(self, emergency=False):
        self.command((0.0,) * len(self.spec.nodes))

    def close(self):
        self.notifier.stop()
        self.bus.shutdown()
'''


def scenario(folder: Path, extra: str = "") -> Path:
    path = folder / "echo.yaml"
    path.write_text(f"""
components:
  right: {{kind: constant, parameters: {{value: 1.5}}}}
  left: {{kind: constant, parameters: {{value: -0.5}}}}
  cmd: {{kind: mux}}
  motor:
    kind: can_drive
    parameters: {{protocol: echo, scale: 1000.0, channel: echo-{os.getpid()},
                 reply_timeout: 0.05, start_timeout: 0.5{extra}}}
connections: [right.y -> cmd.u1, left.y -> cmd.u2, cmd.y -> motor.torque_command]
open: [motor.wheel_speed]
experiment: {{stop: 0.02, step: 0.01, realtime: false}}
""")
    return path


@pytest.fixture
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The package `echo-protocol` on the import path, with a cache of entry points of its
    own."""
    site = tmp_path / "site"
    info = site / "echo_protocol-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: echo-protocol\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[twmr.can_protocols]\necho = echo_protocol:EchoLink\n")
    (site / "echo_protocol.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(site),
                                                      os.environ.get("PYTHONPATH", "")]))
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    registry._group.cache_clear()
    registry._all_groups.cache_clear()
    yield tmp_path
    registry._group.cache_clear()
    registry._all_groups.cache_clear()


@pytest.mark.timeout(120)
def test_the_protocols_options_reach_its_link_emulator_and_decoder(installed: Path) -> None:
    pytest.importorskip("can")
    result = twmr.simulate(scenario(installed), installed / "out")
    torque = [result[f"motor.torque[{i}]"][-1] for i in (1, 2)]
    assert np.allclose(torque, [1.5, -0.5])
    # the emulator answered in wire units scaled by the option, the link scaled them back
    speed = [result[f"motor.measured_speed[{i}]"][-1] for i in (1, 2)]
    assert np.allclose(speed, [1.5, -0.5], atol=1e-6)
    log = installed / "out" / "motor_frames.blf"
    assert log.is_file()
    decoded = subprocess.run([sys.executable, "-m", "twmr.cli", "replay", str(log), "--protocol",
                              "echo", "-o", "scale=1000"], capture_output=True, text=True,
                             timeout=60, cwd=installed)
    assert decoded.returncode == 0, decoded.stderr
    rows = list(csv.DictReader(io.StringIO(decoded.stdout)))
    sent = {(r["node"], float(r["value"])) for r in rows if r["signal"] == "torque_command"}
    assert ("0", 1.5) in sent and ("1", -0.5) in sent


def test_an_option_of_another_protocol_is_named_as_such(installed: Path) -> None:
    with pytest.raises(CosimError, match=r"'firmware' is an option of protocol odrive, not of "
                       r"echo"):
        twmr.load(scenario(installed, ", firmware: 0.6.10"))
    odrive = installed / "odrive.yaml"
    odrive.write_text(scenario(installed).read_text().replace("protocol: echo",
                                                              "protocol: odrive"))
    with pytest.raises(CosimError, match=r"'scale' is an option of protocol echo, not of "
                       r"odrive"):
        twmr.load(odrive)


def test_an_unknown_option_on_the_command_line_lists_the_protocols_own(installed: Path) -> None:
    (installed / "frames.blf").write_bytes(b"")
    out = subprocess.run([sys.executable, "-m", "twmr.cli", "replay", "frames.blf",
                          "--protocol", "echo", "-o", "gain=2"], capture_output=True, text=True,
                         timeout=60, cwd=installed)
    assert out.returncode == 1, out.stderr
    assert "--option gain=2: gain is not an option of protocol echo" in out.stderr
    assert "(scale)" in out.stderr
