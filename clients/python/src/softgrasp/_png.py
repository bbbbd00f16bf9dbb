"""Grey-scale PNG with the standard library: masks and label images to and from numpy arrays."""
from __future__ import annotations

import struct
import zlib

import numpy as np

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def encode_grey(image: np.ndarray) -> bytes:
    """A 2-D uint8 or uint16 array as an 8- or 16-bit grey PNG (counts kept as they are)."""
    if image.ndim != 2 or image.dtype not in (np.uint8, np.uint16):
        raise ValueError("a grey PNG needs a 2-D uint8 or uint16 array, "
                         f"not {image.dtype} {image.shape}")
    height, width = image.shape
    bits = 8 * image.dtype.itemsize
    rows = np.ascontiguousarray(image, dtype=">u2" if bits == 16 else "u1").view(np.uint8)
    raw = np.concatenate([np.zeros((height, 1), np.uint8), rows.reshape(height, -1)], axis=1)
    header = struct.pack(">IIBBBBB", width, height, bits, 0, 0, 0, 0)
    return (_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
            + _chunk(b"IEND", b""))


def _unfilter(kind: int, row: np.ndarray, prior: np.ndarray, bpp: int) -> np.ndarray:
    if kind == 0:
        return row
    if kind == 1:  # Sub: a running sum per byte of the pixel, modulo 256
        return np.cumsum(row.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
    if kind == 2:  # Up
        return row + prior
    out = [0] * len(row)
    raw, up = row.tolist(), prior.tolist()
    for i, x in enumerate(raw):
        left = out[i - bpp] if i >= bpp else 0
        if kind == 3:  # Average
            out[i] = (x + (left + up[i]) // 2) & 0xFF
        elif kind == 4:  # Paeth
            upper_left = up[i - bpp] if i >= bpp else 0
            p = left + up[i] - upper_left
            pa, pb, pc = abs(p - left), abs(p - up[i]), abs(p - upper_left)
            predictor = left if pa <= pb and pa <= pc else up[i] if pb <= pc else upper_left
            out[i] = (x + predictor) & 0xFF
        else:
            raise ValueError(f"PNG row filter {kind} does not exist")
    return np.array(out, np.uint8)


def decode_grey(data: bytes) -> np.ndarray:
    """An 8- or 16-bit grey, non-interlaced PNG (what the server writes) as uint8 or uint16."""
    if not data.startswith(_SIGNATURE):
        raise ValueError("not a PNG")
    pos, idat, header = len(_SIGNATURE), [], b""
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = body
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    width, height, bits, colour, _, _, interlace = struct.unpack(">IIBBBBB", header)
    if colour != 0 or bits not in (8, 16) or interlace != 0:
        raise ValueError(f"only 8/16-bit grey, non-interlaced PNGs are read (bit depth {bits}, "
                         f"colour type {colour}, interlace {interlace})")
    bpp = bits // 8
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(height, 1 + width * bpp)
    pixels = np.zeros((height, width * bpp), np.uint8)
    prior = np.zeros(width * bpp, np.uint8)
    for y in range(height):
        prior = pixels[y] = _unfilter(int(raw[y, 0]), raw[y, 1:], prior, bpp)
    return pixels.view(">u2").astype(np.uint16) if bits == 16 else pixels
