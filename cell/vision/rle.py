"""Run-length coding of binary masks and 8-bit images, and its size beside PNG/JPEG.

A 2-D array is read row by row (C order) as one sequence; each run of equal values
becomes (value, length). A binary mask stores only its first value, since values
alternate. The byte form writes run lengths as LEB128 varints (7 bits per byte, high
bit = more), so short runs cost one byte. An empty array (0 rows or 0 columns) has no
runs; its byte form is the header alone, which keeps its shape. Decoding is bounded:
at most ``MAX_PIXELS`` (2**28) pixels, so a short, forged header cannot allocate gigabytes.

References: Gonzalez & Woods, *Digital Image Processing*, 4th ed., 8.2 (run-length
coding; CCITT Group 3/4 fax uses it for binary documents); LEB128 as in DWARF 5,
section 7.6.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_array, check_int

__all__ = ["CodingSizes", "RunLength", "coding_sizes", "rle_decode", "rle_encode",
           "rle_from_bytes", "rle_to_bytes"]

_MAGIC = b"RLE1"
_HEAD = struct.calcsize("<IIBI")  # bytes after the magic: H, W, flags, run count
MAX_PIXELS = 2**28  # the most pixels a RunLength may describe (a 16384 x 16384 array)
MAX_CODING_PIXELS = 2**22  # the most pixels coding_sizes compares (a 2048 x 2048 array)


@dataclass(frozen=True, eq=False)
class RunLength:
    """Runs of a 2-D array: ``shape`` (H, W), ``binary`` (a bool mask), ``values``
    (uint8, one per run) and ``lengths`` (int64, one per run, summing to H * W; none
    for an empty array)."""

    shape: tuple[int, int]
    binary: bool
    values: np.ndarray
    lengths: np.ndarray


def rle_encode(array: np.ndarray) -> RunLength:
    """Run-length encode a bool mask or uint8 image (H, W), row-major, vectorised; an
    empty array (H or W zero) gives no runs."""
    a = check_array("array", array, dtypes=(np.bool_, np.uint8), ndim=(2,), min_size=0)
    flat = a.ravel().view(np.uint8)
    if flat.size == 0:
        return RunLength(a.shape, a.dtype == np.bool_, np.zeros(0, np.uint8), np.zeros(0, np.int64))
    starts = np.r_[0, np.flatnonzero(flat[1:] != flat[:-1]) + 1]
    lengths = np.diff(np.r_[starts, flat.size]).astype(np.int64)
    return RunLength(a.shape, a.dtype == np.bool_, flat[starts].copy(), lengths)


def _check_runs(name: str, rle: object) -> RunLength:
    """``rle`` a consistent ``RunLength``: ``shape`` two integers >= 0 with at most
    ``MAX_PIXELS`` pixels, ``values`` integers 0..255 (0..1 for a mask, alternating: the
    byte form keeps a mask's first value only) and ``lengths`` integers >= 1, one per
    value, summing to H * W."""
    if not isinstance(rle, RunLength):
        raise VisionError(f"argument '{name}': expected a RunLength, got {type(rle).__name__}")
    shape = rle.shape
    if (not isinstance(shape, tuple) or len(shape) != 2
            or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= 0
                       for v in shape) or int(shape[0]) * int(shape[1]) > MAX_PIXELS):
        raise VisionError(f"argument '{name}': shape must be two integers >= 0 with at most "
                          f"{MAX_PIXELS} pixels in all, got {shape!r}")
    shape = (int(shape[0]), int(shape[1]))  # (numpy integers would overflow below)
    values, lengths = rle.values, rle.lengths
    for field, arr in (("values", values), ("lengths", lengths)):
        if not isinstance(arr, np.ndarray) or arr.ndim != 1 or arr.dtype.kind not in "ui":
            raise VisionError(f"argument '{name}': {field} must be a 1-D integer array, got "
                              f"{getattr(arr, 'dtype', type(arr).__name__)} "
                              f"{getattr(arr, 'shape', '')}")
    top = 1 if rle.binary else 255
    if len(values) != len(lengths) or len(values) > shape[0] * shape[1]:
        raise VisionError(f"argument '{name}': {len(values)} values and {len(lengths)} lengths; "
                          f"expected one of each per run, at most {shape[0] * shape[1]} runs")
    if len(values) and (values.min() < 0 or values.max() > top):
        raise VisionError(f"argument '{name}': values must lie in 0..{top}, got "
                          f"{values.min()}..{values.max()}")
    if len(lengths) and (lengths.min() < 1 or lengths.max() > shape[0] * shape[1]):
        raise VisionError(f"argument '{name}': run lengths must lie in 1..{shape[0] * shape[1]}, "
                          f"got {lengths.min()}..{lengths.max()}")
    if rle.binary and len(values) > 1 and np.any(values[1:] == values[:-1]):
        i = int(np.argmax(values[1:] == values[:-1]))
        raise VisionError(f"argument '{name}': a mask's runs must alternate 0 and 1; runs {i} "
                          f"and {i + 1} are both {int(values[i])}")
    if (total := int(lengths.sum())) != shape[0] * shape[1]:
        raise VisionError(f"argument '{name}': run lengths sum to {total}, "
                          f"not {shape[0]} x {shape[1]}")
    return rle


def rle_decode(rle: RunLength) -> np.ndarray:
    """The array back: bool (H, W) for a mask, uint8 (H, W) otherwise.

    ``rle`` must be consistent (else a ``VisionError`` naming it): ``shape`` at most
    ``MAX_PIXELS`` (2**28) pixels, ``values`` 0..255 (0..1 for a mask), ``lengths`` >= 1,
    one per value, summing to H * W."""
    rle = _check_runs("rle", rle)
    flat = np.repeat(rle.values, rle.lengths)
    out = flat.reshape(rle.shape)
    return out.astype(bool) if rle.binary else out.astype(np.uint8)


def _varint_encode(x: np.ndarray) -> bytes:
    """LEB128 of non-negative integers, vectorised (no integers: no bytes)."""
    x = x.astype(np.uint64)
    nbytes = np.ones(len(x), np.int64)
    for k in range(1, 10):
        nbytes += (x >> np.uint64(7 * k)) > 0
    total = int(nbytes.sum())
    owner = np.repeat(np.arange(len(x)), nbytes)
    first = np.cumsum(nbytes) - nbytes  # offset of each integer's first byte
    k = np.arange(total) - np.repeat(first, nbytes)
    groups = (x[owner] >> (np.uint64(7) * k.astype(np.uint64))) & np.uint64(0x7F)
    more = (k < nbytes[owner] - 1).astype(np.uint64) << np.uint64(7)
    return (groups | more).astype(np.uint8).tobytes()


def _varint_decode(buf: np.ndarray, count: int) -> tuple[np.ndarray, int]:
    """``count`` LEB128 integers from the start of ``buf``; returns them and bytes used.
    An integer longer than 5 bytes (over 2**35) is refused: no run is that long."""
    ends = np.flatnonzero(buf < 0x80)
    if len(ends) < count:
        raise VisionError("argument 'data': truncated run lengths")
    ends = ends[:count]
    used = int(ends[-1]) + 1 if count else 0
    starts = np.r_[0, ends[:-1] + 1] if count else np.zeros(0, np.int64)
    if count and int((ends - starts).max()) >= 5:
        raise VisionError("argument 'data': a run length takes more than 5 bytes (over 2**35)")
    idx = np.arange(used)
    owner = np.repeat(np.arange(count), ends - starts + 1)
    k = idx - starts[owner]
    vals = (buf[:used].astype(np.uint64) & np.uint64(0x7F)) << (np.uint64(7) * k.astype(np.uint64))
    out = np.zeros(count, np.uint64)
    np.add.at(out, owner, vals)
    return out.astype(np.int64), used


def rle_to_bytes(rle: RunLength) -> bytes:
    """Serialise: magic, H, W (uint32), flags, run count, values (one byte for a mask:
    the first value; one per run otherwise), then the lengths as LEB128 varints. With
    no runs (an empty array) only the 17-byte header is written. ``rle`` must be
    consistent, as for :func:`rle_decode`."""
    rle = _check_runs("rle", rle)
    head = _MAGIC + struct.pack("<IIBI", rle.shape[0], rle.shape[1], int(rle.binary),
                                len(rle.lengths))
    values = rle.values[:1].tobytes() if rle.binary else rle.values.astype(np.uint8).tobytes()
    return head + values + _varint_encode(rle.lengths)


def rle_from_bytes(data: bytes) -> RunLength:
    """Parse :func:`rle_to_bytes` output back into a ``RunLength``.

    Anything but exactly that is a ``VisionError`` naming ``data``: a short header, a
    flag other than 0 or 1, more runs than the bytes hold or than H * W, a run length
    out of 1..H * W or over 5 bytes, lengths not summing to H * W, trailing bytes, or
    over ``MAX_PIXELS`` (2**28) pixels."""
    if not isinstance(data, bytes | bytearray) or data[:4] != _MAGIC:
        raise VisionError("argument 'data': not run-length data (bad magic)")
    if len(data) < 4 + _HEAD:
        raise VisionError(f"argument 'data': truncated header ({len(data)} bytes, need {4 + _HEAD})")
    h, w, binary, n = struct.unpack_from("<IIBI", data, 4)
    pos = 4 + _HEAD
    need = (1 if binary else n) + n if n else 0  # values, then a byte at least per length
    if binary > 1 or h * w > MAX_PIXELS or n > h * w or len(data) - pos < need:
        raise VisionError(f"argument 'data': header ({h} x {w}, flags {binary}, {n} runs) does "
                          f"not fit its {len(data) - pos} bytes of runs (at most {MAX_PIXELS} "
                          "pixels, flags 0 or 1, a run per pixel at most)")
    buf = np.frombuffer(data, np.uint8)
    if binary:
        first = int(buf[pos]) if n else 0
        values = ((first + np.arange(n)) % 2).astype(np.uint8)
        pos += 1 if n else 0
        if first > 1:
            raise VisionError(f"argument 'data': a mask's first value must be 0 or 1, got {first}")
    else:
        values = buf[pos : pos + n].copy()
        pos += n
    lengths, used = _varint_decode(buf[pos:], n)
    if pos + used != len(data):
        raise VisionError(f"argument 'data': {len(data) - pos - used} bytes after the last run")
    return _check_runs("data", RunLength((h, w), bool(binary), values, lengths))


@dataclass(frozen=True)
class CodingSizes:
    """Bytes needed to store one array: ``raw`` (1 bit per pixel for a mask, 1 byte
    otherwise), ``rle`` (:func:`rle_to_bytes`), ``png`` (lossless, level 9), ``jpeg``
    (quality ``jpeg_quality``) and ``jpeg_wrong``: pixels that differ after the JPEG
    round trip (a mask is re-thresholded at 128)."""

    raw: int
    rle: int
    png: int
    jpeg: int
    jpeg_quality: int
    jpeg_wrong: int


def coding_sizes(array: np.ndarray, *, jpeg_quality: int = 90) -> CodingSizes:
    """Compare RLE with PNG and JPEG (``cv2.imencode``) on a mask or grey image (H, W).

    array : bool or uint8 (H, W), at most ``MAX_CODING_PIXELS`` (2**22, 2048 x 2048) pixels
    (a noisy mask that size takes seconds: PNG level 9, the varints).
    jpeg_quality : integer 0..100 (``cv2.IMWRITE_JPEG_QUALITY``)."""
    a = check_array("array", array, dtypes=(np.bool_, np.uint8), ndim=(2,))
    if a.size > MAX_CODING_PIXELS:
        raise VisionError(f"argument 'array': {a.shape[0]} x {a.shape[1]} is over "
                          f"{MAX_CODING_PIXELS} pixels (2048 x 2048)")
    jpeg_quality = check_int("jpeg_quality", jpeg_quality, 0, 100)
    binary = a.dtype == np.bool_
    img = a.view(np.uint8) * np.uint8(255) if binary else a
    ok1, png = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    ok2, jpg = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
    if not (ok1 and ok2):
        raise VisionError("argument 'array': OpenCV could not encode it")
    back = cv2.imdecode(jpg, cv2.IMREAD_GRAYSCALE)
    wrong = int(np.sum((back >= 128) != a)) if binary else int(np.sum(back != a))
    raw = (a.size + 7) // 8 if binary else a.size
    return CodingSizes(raw, len(rle_to_bytes(rle_encode(a))), len(png), len(jpg),
                       int(jpeg_quality), wrong)
