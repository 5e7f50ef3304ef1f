import numpy as np
import pytest

from mmocap.bitmask import pack_rows, unpack_rows


@pytest.mark.parametrize("width", [1, 31, 32, 64, 65, 640])
def test_rows_pack_into_whole_words_and_back_whatever_the_width(width):
    mask = np.random.default_rng(width).random((5, width)) > 0.5
    packed = pack_rows(mask)
    assert packed.dtype == np.dtype("<u4")
    assert packed.shape == (5, -(-width // 32))
    np.testing.assert_array_equal(unpack_rows(packed, width), mask)
    bits = np.unpackbits(packed.view(np.uint8), axis=1, bitorder="little")
    assert not bits[:, width:].any()  # zeros past the last pixel
    np.testing.assert_array_equal(pack_rows(mask.astype(np.uint8) * 7), packed)  # nonzero = set
