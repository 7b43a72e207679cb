"""The ``compress`` job: a frame through a codec and back, then the detector on what came out.

The scene is the detect job's (:mod:`cell.sweep.jobs.detect`). ``job.codec`` encodes its
outline image: ``png`` (lossless, ``cv2.imencode`` level 9), ``jpeg`` (lossy, at
``job.quality``, the colour at half resolution (``job.chroma = "420"``, OpenCV's
default) or full (``"444"``)) or ``rle`` (each colour channel run-length coded by
:func:`cell.vision.rle_to_bytes`, each stream after its 4-byte length; lossless, and it
pays only where long runs of one value are, as in masks). The decoded image goes through
the detector and is scored as in the detect job. A ``rle`` run also codes the frame's
binary part mask (the ground truth's parts, as a labelling tool stores them): RLE against
1 bit per pixel and PNG.

Figures: ``bytes`` per frame, ``ratio`` (raw 24-bit frame / bytes), ``bits_per_pixel``,
``psnr_db`` of the decoded image (None when lossless), the detect job's accuracy figures
on it, and for ``rle`` ``mask_rle_bytes``, ``mask_png_bytes``, ``mask_raw_bytes`` and
``mask_ratio`` (raw bits / RLE). Timings: ``encode_ms``, ``decode_ms``, ``detect_ms``.
"""

from __future__ import annotations

import math
import struct
import time
from dataclasses import dataclass

import numpy as np

from cell.config import check, setting
from cell.scenario import Scenario
from cell.sweep.errors import SweepError
from cell.sweep.jobs.detect import prepare, scene_key  # the detect job's scene (its gap_mm)

__all__ = ["CHROMA", "CODECS", "METRICS", "TIMINGS", "Settings", "decode", "encode", "measure", "prepare",
           "scene_key"]

CODECS = ("png", "jpeg", "rle")
CHROMA = ("420", "444")
_ACCURACY = ("recall", "false_detections", "kind_accuracy", "material_accuracy",
             "classification_accuracy", "position_error_mm_mean", "position_error_mm_max")
METRICS = ("bytes", "ratio", "bits_per_pixel", "psnr_db", *_ACCURACY, "mask_rle_bytes",
           "mask_png_bytes", "mask_raw_bytes", "mask_ratio")
TIMINGS = ("encode_ms", "decode_ms", "detect_ms")


@dataclass(frozen=True)
class Settings:
    """The compress job's parameters (``[job]``)."""

    codec: str = setting("png", choices=CODECS, doc="png, jpeg or rle (per colour channel)")
    quality: int = setting(90, lo=0, hi=100, doc="JPEG quality (0-100; only for jpeg)")
    chroma: str = setting("420", choices=CHROMA,
                          doc="JPEG chroma sampling: 420 (colour at half resolution both ways, "
                          "OpenCV's default) or 444 (full resolution)")
    gap_mm: float = setting(4.0, lo=0.0, hi=100.0,
                            doc="least gap between two parts' bounding circles in the scene (mm)")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)



def encode(image: np.ndarray, settings: Settings) -> bytes:
    """``image`` (uint8 RGB (H, W, 3)) coded by ``settings.codec``."""
    import cv2

    if settings.codec == "rle":
        from cell.vision.rle import rle_encode, rle_to_bytes

        streams = [rle_to_bytes(rle_encode(np.ascontiguousarray(image[..., c]))) for c in range(3)]
        return b"".join(struct.pack("<I", len(b)) + b for b in streams)  # each with its length
    bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    sampling = (cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444 if settings.chroma == "444"
                else cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420)
    params = ([cv2.IMWRITE_PNG_COMPRESSION, 9] if settings.codec == "png"
              else [cv2.IMWRITE_JPEG_QUALITY, int(settings.quality),
                    cv2.IMWRITE_JPEG_SAMPLING_FACTOR, sampling])
    ok, data = cv2.imencode(".png" if settings.codec == "png" else ".jpg", bgr, params)
    if not ok:
        raise SweepError(f"OpenCV could not encode the frame as {settings.codec}")
    return data.tobytes()


def decode(data: bytes, settings: Settings) -> np.ndarray:
    """The image back from :func:`encode`'s bytes (uint8 RGB)."""
    import cv2

    if settings.codec == "rle":
        from cell.vision.rle import rle_decode, rle_from_bytes

        channels, at = [], 0
        for _ in range(3):
            (n,) = struct.unpack_from("<I", data, at)
            channels.append(rle_decode(rle_from_bytes(data[at + 4: at + 4 + n])))
            at += 4 + n
        return np.ascontiguousarray(np.stack(channels, axis=-1))
    bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _mask_figures(seg: np.ndarray) -> dict:
    import cv2

    from cell.vision.rle import rle_encode, rle_to_bytes

    mask = seg > 0
    rle = len(rle_to_bytes(rle_encode(mask)))
    ok, png = cv2.imencode(".png", mask.view(np.uint8) * np.uint8(255), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    raw = (mask.size + 7) // 8
    return {"mask_rle_bytes": rle, "mask_png_bytes": len(png) if ok else None,
            "mask_raw_bytes": raw, "mask_ratio": raw / rle}


def measure(scene: object, scenario: Scenario, settings: Settings) -> dict:
    import cv2

    from cell.jobs.detectors import load_detector
    from cell.sweep.scoring import figures, score_frame

    image = scene.image
    t0 = time.perf_counter()
    data = encode(image, settings)
    t1 = time.perf_counter()
    back = decode(data, settings)
    t2 = time.perf_counter()
    detections = load_detector(scenario.vision).detect(back, scene.camera)
    t3 = time.perf_counter()
    scored = figures(score_frame(scene, detections))
    psnr = float(cv2.PSNR(image, back))
    out = {"bytes": len(data), "ratio": image.nbytes / len(data),
           "bits_per_pixel": 8.0 * len(data) / (image.shape[0] * image.shape[1]),
           "psnr_db": psnr if math.isfinite(psnr) and not np.array_equal(image, back) else None}
    out.update({k: scored[k] for k in _ACCURACY})
    out.update(dict.fromkeys(("mask_rle_bytes", "mask_png_bytes", "mask_raw_bytes", "mask_ratio")))
    if settings.codec == "rle":
        out.update(_mask_figures(scene.seg))
    out.update(encode_ms=1e3 * (t1 - t0), decode_ms=1e3 * (t2 - t1), detect_ms=1e3 * (t3 - t2))
    return out
