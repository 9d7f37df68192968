"""The C twins of the CAN drive protocols (hw/c/odrive.c, hw/c/cia402.c) and of the FMI-LS-BUS
CAN framing (src/twmr/fmi/cexport/c/lsbus.c) give the bytes and values of their Python
definitions (twmr.hw.protocol, twmr.hw.cia402, twmr.fmi.lsbus.operations) on random values:
bit for bit (a float is compared by its bits). The C files are compiled once per session into a
library called through ctypes, with the flags of the FMU export (its symbols visible)."""
from __future__ import annotations

import ctypes
import math
import os
import struct
import subprocess

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twmr.fmi.cexport import C_DIR, CFLAGS
from twmr.fmi.lsbus.operations import CanTransmit, decode, encode
from twmr.hw import c_nodes
from twmr.hw import cia402 as c
from twmr.hw import protocol as p

SETTINGS = settings(max_examples=300, deadline=None, derandomize=True, database=None)
F32_MAX = 3.4028234663852886e38
#: values whose float32 exists (struct.pack('<f') refuses larger ones)
finite = st.floats(-1e30, 1e30, allow_nan=False)
gears = st.floats(1e-3, 1e3)
u8 = ctypes.c_ubyte * 8


@pytest.fixture(scope="session")
def lib(tmp_path_factory: pytest.TempPathFactory) -> ctypes.CDLL:
    out = tmp_path_factory.mktemp("can_codec") / "codec.so"
    sources = [c_nodes.C / "odrive.c", c_nodes.C / "cia402.c", C_DIR / "lsbus.c"]
    flags = [f for f in CFLAGS if not f.startswith("-fvisibility")]  # the symbols are called
    subprocess.run([os.environ.get("CC", "cc"), *flags, "-shared", f"-I{C_DIR}",
                    *map(str, sources), "-o", str(out), "-lm"], check=True)
    so = ctypes.CDLL(str(out))
    d, u, ul, i, lg = ctypes.c_double, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int, ctypes.c_long
    for name, res, args in (
            ("odrive_can_id", u, [u, u]),
            ("odrive_encode_torque", u, [d, d, u8]), ("odrive_decode_torque", d, [u8, d]),
            ("odrive_encode_axis_state", u, [u, u8]),
            ("odrive_encode_controller_mode", u, [u, u, u8]),
            ("odrive_encode_limits", u, [d, d, d, u8]),
            ("odrive_encode_clear_errors", u, [i, u8]),
            ("odrive_decode_encoder", None, [u8, d, ctypes.POINTER(d), ctypes.POINTER(d)]),
            ("odrive_split_id", None, [ul, ctypes.POINTER(u), ctypes.POINTER(u)]),
            ("cia402_state", i, [u]), ("cia402_next_controlword", u, [i]),
            ("cia402_torque_to_permille", i, [d, d, lg]),
            ("cia402_permille_to_torque", d, [lg, d, lg]),
            ("cia402_velocity_to_si", d, [lg, d, d]),
            ("cia402_encode_rpdo1", u, [u, i, u8]),
            ("cia402_decode_tpdo1", None, [u8, ctypes.POINTER(u), ctypes.POINTER(lg)])):
        fn = getattr(so, name)
        fn.restype, fn.argtypes = res, args
    so.lsbus_next.restype = ctypes.c_long
    so.lsbus_transmit.restype = None
    return so


def _bits(x: float) -> bytes:
    return struct.pack("<d", x)


def _frame(fn, *args) -> bytes:  # type: ignore[no-untyped-def]
    data = u8()
    n = fn(*args, data)
    return bytes(data)[:n]


# -- ODrive CAN Simple -----------------------------------------------------------------------
@SETTINGS
@given(node=st.integers(0, 63), cmd=st.integers(0, 31))
def test_odrive_identifiers(lib: ctypes.CDLL, node: int, cmd: int) -> None:
    ident = lib.odrive_can_id(node, cmd)
    assert ident == p.can_id(node, cmd)
    n, k = ctypes.c_uint(), ctypes.c_uint()
    lib.odrive_split_id(ident, ctypes.byref(n), ctypes.byref(k))
    assert (n.value, k.value) == p.split_id(ident)


@SETTINGS
@given(tau=finite, gear=gears)
def test_odrive_torque_frame(lib: ctypes.CDLL, tau: float, gear: float) -> None:
    if abs(tau / gear) > F32_MAX:
        return
    data = _frame(lib.odrive_encode_torque, tau, gear)
    assert data == p.encode_torque(0, tau, gear)[1]
    assert _bits(lib.odrive_decode_torque(u8(*data), gear)) == _bits(p.decode_torque(data, gear))


@SETTINGS
@given(raw=st.binary(min_size=8, max_size=8), gear=gears)
def test_odrive_encoder_estimates(lib: ctypes.CDLL, raw: bytes, gear: float) -> None:
    angle, speed = ctypes.c_double(), ctypes.c_double()
    lib.odrive_decode_encoder(u8(*raw), gear, ctypes.byref(angle), ctypes.byref(speed))
    want = p.decode_encoder(raw, gear)
    got = (angle.value, speed.value)
    assert [math.isnan(x) for x in got] == [math.isnan(x) for x in want]
    assert [_bits(x) for x in got if not math.isnan(x)] == \
        [_bits(x) for x in want if not math.isnan(x)]


@SETTINGS
@given(speed=st.floats(0.0, 1e6), current=st.floats(0.0, 1e6), gear=gears,
       state=st.integers(0, 2**32 - 1), control=st.integers(0, 2**32 - 1),
       mode=st.integers(0, 2**32 - 1))
def test_odrive_configuration_frames(lib: ctypes.CDLL, speed: float, current: float,
                                     gear: float, state: int, control: int, mode: int) -> None:
    assert _frame(lib.odrive_encode_limits, speed, current, gear) == \
        p.encode_limits(0, speed, current, gear)[1]
    assert _frame(lib.odrive_encode_axis_state, state) == p.encode_axis_state(0, state)[1]
    assert _frame(lib.odrive_encode_controller_mode, control, mode) == \
        p.encode_controller_mode(0, control, mode)[1]


@pytest.mark.parametrize("firmware", ["0.5.6", "0.6.10"])
def test_odrive_clear_errors(lib: ctypes.CDLL, firmware: str) -> None:
    line = c_nodes._odrive_options({"firmware": firmware})["ODRIVE_LINE"]
    assert _frame(lib.odrive_encode_clear_errors, line) == p.encode_clear_errors(0, firmware)[1]


# -- CiA 402 ---------------------------------------------------------------------------------
def test_cia402_every_statusword_and_state(lib: ctypes.CDLL) -> None:
    states = list(c.State)
    for word in range(0x10000):
        try:
            want = states.index(c.decode_statusword(word))
        except ValueError:
            want = -1
        assert lib.cia402_state(word) == want, hex(word)
    for k, state in enumerate(states):
        assert lib.cia402_next_controlword(k) == c.next_controlword(state), state


@SETTINGS
@given(tau=finite, gear=gears, rated=st.integers(1, 10**7), permille=st.integers(-32768, 32767),
       velocity=st.integers(-2**31, 2**31 - 1), per_unit=st.floats(1e-3, 1e3))
def test_cia402_scalings(lib: ctypes.CDLL, tau: float, gear: float, rated: int, permille: int,
                         velocity: int, per_unit: float) -> None:
    assert lib.cia402_torque_to_permille(tau, gear, rated) == \
        c.torque_to_permille(tau, gear, rated)
    assert _bits(lib.cia402_permille_to_torque(permille, gear, rated)) == \
        _bits(c.permille_to_torque(permille, gear, rated))
    assert _bits(lib.cia402_velocity_to_si(velocity, gear, per_unit)) == \
        _bits(c.velocity_to_si(velocity, gear, per_unit))


@SETTINGS
@given(word=st.integers(0, 0xFFFF), permille=st.integers(-32768, 32767),
       raw=st.binary(min_size=8, max_size=8))
def test_cia402_pdos(lib: ctypes.CDLL, word: int, permille: int, raw: bytes) -> None:
    assert _frame(lib.cia402_encode_rpdo1, word, permille) == \
        c.encode_rpdo1(1, word, permille)[1]
    status, velocity = ctypes.c_uint(), ctypes.c_long()
    lib.cia402_decode_tpdo1(u8(*raw), ctypes.byref(status), ctypes.byref(velocity))
    assert (status.value, velocity.value) == c.decode_tpdo1(raw)


# -- FMI-LS-BUS CAN Transmit -----------------------------------------------------------------
class _Frame(ctypes.Structure):
    _fields_ = [("id", ctypes.c_ulong), ("ide", ctypes.c_int), ("rtr", ctypes.c_int),
                ("length", ctypes.c_uint), ("data", ctypes.POINTER(ctypes.c_ubyte))]


class _Buffer(ctypes.Structure):
    _fields_ = [("b", ctypes.c_ubyte * 1024), ("n", ctypes.c_size_t), ("overflow", ctypes.c_int)]


frames = st.builds(
    lambda ident, ide, rtr, data: CanTransmit(ident, b"" if rtr else data, ide, rtr,
                                              len(data) if rtr else None),
    st.integers(0, 2**29 - 1), st.booleans(), st.booleans(), st.binary(max_size=8))


@SETTINGS
@given(ops=st.lists(frames, max_size=6))
def test_lsbus_can_transmit(lib: ctypes.CDLL, ops: list[CanTransmit]) -> None:
    buf = _Buffer()
    for op in ops:
        data = (ctypes.c_ubyte * 8)(*op.data)
        lib.lsbus_transmit(ctypes.byref(buf), ctypes.byref(
            _Frame(op.id, op.ide, op.rtr, op.data_length, data)))
    raw = bytes(buf.b)[:buf.n]
    assert raw == encode(ops)
    assert decode(raw) == ops
    at, code, got = 0, ctypes.c_uint(), []
    array = (ctypes.c_ubyte * max(1, len(raw))).from_buffer_copy(raw or b"\0")
    while True:
        f = _Frame()
        at = lib.lsbus_next(array, ctypes.c_size_t(len(raw)), ctypes.c_size_t(at),
                            ctypes.byref(code), ctypes.byref(f))
        if at <= 0:
            break
        data = b"" if f.rtr else bytes(f.data[:f.length])
        got.append(CanTransmit(f.id, data, bool(f.ide), bool(f.rtr),
                               f.length if f.rtr else None))
    assert at == 0
    assert got == ops
