"""The row-packed bit layout of foreground masks, shared by the foreground stage, its cache
and the evaluators that count with popcounts.

A row of W pixels is ``ceil(W / 32)`` little-endian uint32 words: pixel x is bit x % 32 of
word x // 32; padding bits past W are 0.
"""

from __future__ import annotations

import numpy as np

WORD_BITS = 32


def words_per_row(width: int) -> int:
    """Number of uint32 words that hold a row of ``width`` pixels."""
    return (width + WORD_BITS - 1) // WORD_BITS


def pack_rows(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool -> (H, ceil(W / 32)) little-endian uint32 in the layout above."""
    mask = np.asarray(mask, dtype=bool)
    H, W = mask.shape
    if W % WORD_BITS:  # whole words: zeros past the last pixel
        padded = np.zeros((H, words_per_row(W) * WORD_BITS), bool)
        padded[:, :W] = mask
        mask = padded
    return np.packbits(mask, axis=1, bitorder="little").view("<u4")


def unpack_rows(packed: np.ndarray, width: int) -> np.ndarray:
    """Inverse of :func:`pack_rows`: (H, ceil(W / 32)) uint32 -> (H, W) bool."""
    bits = np.unpackbits(np.ascontiguousarray(packed, dtype="<u4").view(np.uint8), axis=1, bitorder="little")
    return bits[:, :width].astype(bool)


class ForegroundMask(np.ndarray):
    """(H, W) bool foreground of one camera, with ``packed`` (:func:`pack_rows`) and
    ``area`` = |F| in pixels.

    Arrays derived from a mask (views, results of operations) are plain masks again:
    their ``packed`` and ``area`` are None.
    """

    packed: np.ndarray | None
    area: int | None

    def __new__(cls, mask: np.ndarray, packed: np.ndarray | None = None) -> ForegroundMask:
        mask = np.asarray(mask, dtype=bool)
        if mask.ndim != 2:
            raise ValueError(f"a foreground mask is (H, W), got shape {mask.shape}")
        obj = mask.view(cls)
        obj.packed = pack_rows(mask) if packed is None else packed
        obj.area = int(np.count_nonzero(mask))
        return obj

    def __array_finalize__(self, obj) -> None:
        self.packed = None
        self.area = None

    def __reduce__(self):
        return (ForegroundMask, (np.asarray(self),))
