"""Argument checks of the robot's public functions: a bad number is a ``CellError`` naming
the argument, never a NaN that travels on into a plan or a raw numpy/pinocchio error."""

from __future__ import annotations

import math
import numbers

import numpy as np

from cell.errors import CellError


def finite(name: str, value: object, error: type[CellError]) -> float:
    """``value`` as a float when it is a finite real number (not a bool); else ``error``."""
    if (isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
            and math.isfinite(value)):
        return float(value)
    raise error(f"argument {name!r}: expected a finite number, got {value!r}")


def finite_vector(name: str, value: object, size: int, error: type[CellError]) -> np.ndarray:
    """``value`` as float64 (size,) when it holds ``size`` finite numbers; else ``error``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (size,) or not np.isfinite(arr).all():
        shown = arr.tolist() if arr is not None and arr.size <= 16 else getattr(value, "shape", value)
        raise error(f"argument {name!r}: expected {size} finite numbers, got {shown!r}")
    return arr
