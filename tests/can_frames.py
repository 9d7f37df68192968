"""CAN frame timing counted independently of twmr.hw.cansim, for the LS-BUS bus tests: a
classic frame's bits from its fields, CRC-15 and stuffing rule."""
from __future__ import annotations

import math


def crc15(bits: str) -> int:
    """The CAN CRC-15 (polynomial 0x4599) of a bit string, computed bit by bit."""
    crc = 0
    for bit in bits:
        top = int(bit) ^ (crc >> 14) & 1
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= 0x4599
    return crc


def bits_to_eof(ident: int, data: bytes) -> int:
    """Bits of a classic 11-bit data frame from SOF to the end of EOF: SOF, id, RTR, IDE, r0,
    DLC, data, CRC-15 with a stuff bit after every 5 equal bits (the stuff bit counts in the
    next run), then CRC delimiter, ACK slot, ACK delimiter and 7 EOF bits."""
    body = "0" + f"{ident:011b}" + "000" + f"{len(data):04b}" + \
        "".join(f"{b:08b}" for b in data)
    body += f"{crc15(body):015b}"
    stuffed, last, run = 0, "", 0
    for bit in body:
        run = run + 1 if bit == last else 1
        last = bit
        if run == 5:
            stuffed += 1
            last, run = ("1" if bit == "0" else "0"), 1
    return len(body) + stuffed + 10


def grid_after(t: float, h: float = 1e-4) -> float:
    """The first communication point at or after t [s] on a grid of step h [s]."""
    return round(math.ceil(round(t / h, 6)) * h, 9)
