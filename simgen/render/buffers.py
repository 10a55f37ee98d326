"""Output arrays that compiled loops fill without knowing their final length: double when full."""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True)
def grow(array: NDArray, capacity: int) -> NDArray:
    """A copy of `array` (1-D or 2-D) with room for `capacity` rows."""
    out = np.empty((capacity,) + array.shape[1:], array.dtype)
    out[: len(array)] = array
    return out
