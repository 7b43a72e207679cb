"""Input validation shared by the vision functions.

Every public vision function that takes an array checks it here first, so a wrong
dtype, number of dimensions or shape is a ``VisionError`` that names the argument and
says what was expected, instead of an OpenCV assertion deep inside a call.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable

import numpy as np

from cell.errors import VisionError
from cell.text import show

MAX_SIZE = 4095  # pixels: the largest kernel, block or window side a vision function takes


def _dtype_names(dtypes: Iterable[np.dtype | type]) -> str:
    return ", ".join(np.dtype(d).name for d in dtypes)


def check_array(
    name: str,
    value: object,
    *,
    dtypes: tuple[type, ...] | None = None,
    ndim: tuple[int, ...] | None = None,
    channels: tuple[int, ...] | None = None,
    min_size: int = 1,
) -> np.ndarray:
    """Return ``value`` as an ndarray after checking dtype, ndim and channel count.

    ``channels`` applies to 3-D arrays only (the last axis). ``min_size`` is the
    smallest allowed height and width (pixels).
    """
    if not isinstance(value, np.ndarray):
        raise VisionError(f"argument '{name}': expected a numpy array, got {type(value).__name__}")
    if dtypes is not None and value.dtype not in [np.dtype(d) for d in dtypes]:
        swapped = not value.dtype.isnative
        raise VisionError(
            f"argument '{name}': dtype {value.dtype.name}"
            f"{' in non-native byte order' if swapped else ''} not supported "
            f"(valid: {_dtype_names(dtypes)}{', native byte order' if swapped else ''})"
        )
    if ndim is not None and value.ndim not in ndim:
        raise VisionError(
            f"argument '{name}': expected {' or '.join(map(str, ndim))} dimensions, "
            f"got shape {value.shape}"
        )
    if channels is not None and value.ndim == 3 and value.shape[2] not in channels:
        raise VisionError(
            f"argument '{name}': expected {' or '.join(map(str, channels))} channels, "
            f"got shape {value.shape}"
        )
    if value.ndim >= 2 and (value.shape[0] < min_size or value.shape[1] < min_size):
        raise VisionError(
            f"argument '{name}': image must be at least {min_size}x{min_size}, got {value.shape}"
        )
    return value


def check_gray(name: str, value: object, *, dtypes: tuple[type, ...] = (np.uint8,)) -> np.ndarray:
    """A single-channel image (H, W) of one of ``dtypes``."""
    return check_array(name, value, dtypes=dtypes, ndim=(2,))


def check_image(
    name: str, value: object, *, dtypes: tuple[type, ...] = (np.uint8,)
) -> np.ndarray:
    """A grey (H, W) or 3-channel colour (H, W, 3) image of one of ``dtypes``."""
    return check_array(name, value, dtypes=dtypes, ndim=(2, 3), channels=(3,))


def check_colour(name: str, value: object, *, dtypes: tuple[type, ...] = (np.uint8,)) -> np.ndarray:
    """A 3-channel colour image (H, W, 3) of one of ``dtypes``."""
    check_array(name, value, dtypes=dtypes, ndim=(3,), channels=(3,))
    return value  # type: ignore[return-value]


def check_mask(name: str, value: object) -> np.ndarray:
    """A binary mask (H, W), bool or uint8 (non-zero is set); returned as bool."""
    arr = check_array(name, value, dtypes=(np.bool_, np.uint8), ndim=(2,))
    return arr if arr.dtype == np.bool_ else arr > 0


def check_points(name: str, value: object, *, dim: int = 2, count: int | None = None) -> np.ndarray:
    """Points as an (N, dim) float64 array; ``count`` fixes N when given."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise VisionError(f"argument '{name}': expected an (N, {dim}) array of numbers") from None
    if arr.ndim == 1 and arr.shape[0] == dim:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise VisionError(f"argument '{name}': expected shape (N, {dim}), got {arr.shape}")
    if count is not None and arr.shape[0] != count:
        raise VisionError(f"argument '{name}': expected {count} points, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise VisionError(f"argument '{name}': points must be finite")
    return arr


def check_choice(name: str, value: object, choices: tuple) -> None:
    """``value`` must be one of ``choices``; the error lists them. A choice among
    integers (``connectivity`` 4 or 8) takes an integer, not ``4.0`` or ``True``."""
    if all(_is_int(c) for c in choices) and not _is_int(value):
        valid = False
    else:
        try:
            valid = value in choices
        except (TypeError, ValueError):  # an array compared with the choices
            valid = False
    if not valid:
        raise VisionError(
            f"argument '{name}': {show(value)} is not valid (valid: {', '.join(map(repr, choices))})"
        )


def check_odd(name: str, value: object, *, minimum: int = 1, maximum: int = MAX_SIZE) -> None:
    """An odd integer from ``minimum`` to ``maximum`` (kernel and block sizes)."""
    if not _is_int(value) or not minimum <= value <= maximum or value % 2 == 0:
        raise VisionError(f"argument '{name}': expected an odd integer from {minimum} to {maximum}, "
                          f"got {show(value)}")


def check_int(name: str, value: object, lo: int, hi: int) -> int:
    """An integer (not a bool, not a float) with ``lo <= value <= hi``; returned as ``int``."""
    if not _is_int(value) or not lo <= value <= hi:
        raise VisionError(f"argument '{name}': expected an integer from {lo} to {hi}, got {show(value)}")
    return int(value)


def check_range(name: str, value: object, lo: float, hi: float) -> float:
    """A real number (not a bool, a string or an array; finite unless a bound is infinite)
    with ``lo <= value <= hi``; returned as ``float``."""
    if not _is_real(value) or not (lo <= value <= hi):
        raise VisionError(f"argument '{name}': {show(value)} is outside [{lo}, {hi}]"
                          if _is_real(value) else
                          f"argument '{name}': expected a number in [{lo}, {hi}], got {show(value)}")
    return float(value)


def check_finite(name: str, value: np.ndarray) -> np.ndarray:
    """A float array whose values are all finite (a NaN or inf pixel would spread through a
    filter or a match score); integer arrays pass unchecked."""
    if value.dtype.kind == "f" and not np.isfinite(value).all():
        raise VisionError(f"argument '{name}': holds NaN or infinite values; every value must be finite")
    return value


def _is_int(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _is_real(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
