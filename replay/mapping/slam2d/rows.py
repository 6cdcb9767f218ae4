"""``Rows``: an array that grows a row at a time, for per-keyframe values read whole at every keyframe.

Appending to a Python list and turning it into an array at each read costs a pass over every row in
the interpreter; a NumPy buffer that doubles when full appends in amortised constant time and reads
as a view.
"""

from __future__ import annotations

import numpy as np


class Rows:
    """Rows of a fixed shape (``row_shape``, float64), appended one at a time; ``view()`` is the filled part."""

    def __init__(self, row_shape: tuple[int, ...], capacity: int = 64) -> None:
        self._buffer = np.zeros((max(1, capacity), *row_shape))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, row) -> None:
        """Add ``row`` (an array of the row shape, or a sequence NumPy reads as one) at the end; another shape
        raises ``ValueError`` (NumPy would broadcast a (3,) row into a (3, 3) one)."""
        if np.shape(row) != self._buffer.shape[1:]:
            raise ValueError(f"a row of shape {self._buffer.shape[1:]} expected, got {np.shape(row)}")
        if self._n == len(self._buffer):
            self._buffer = np.concatenate([self._buffer, np.zeros_like(self._buffer)])
        self._buffer[self._n] = row
        self._n += 1

    def view(self) -> np.ndarray:
        """The rows so far, a writable view of the buffer (valid until the next ``append``)."""
        return self._buffer[: self._n]
