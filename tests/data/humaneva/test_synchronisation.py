"""The ``.ofs`` arithmetic, and the toolbox's frame numbers."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.data.humaneva.synchronisation import SyncOffsets, toolbox_frame_offsets
from tests.helpers import damages, read_damaged


def test_sync_offsets_arithmetic(tmp_path):
    sync = SyncOffsets(image_start=3, mocap_start=10, mocap_scale=2.0)
    np.testing.assert_allclose(sync.mocap_index([3, 4, 10]), [10, 12, 24])
    np.testing.assert_allclose(sync.image_index(sync.mocap_index([1.0, 7.5])), [1.0, 7.5])
    sync.save(tmp_path / "a.ofs")
    assert SyncOffsets.load(tmp_path / "a.ofs") == sync


def test_toolbox_frame_numbering():
    # mocap starting after the videos: toolbox frame 1 is mocap frame 1
    assert toolbox_frame_offsets([SyncOffsets(10, 1, 2.0), SyncOffsets(9, 1, 2.0)]).tolist() == [10, 9]
    # mocap starting first: toolbox frame 1 is the earliest camera's first image
    assert toolbox_frame_offsets([SyncOffsets(2, 5, 2.0), SyncOffsets(1, 5, 2.0)]).tolist() == [2, 1]
    # the second camera's image 1 at mocap 6: the first's image 2.5 at that time, rounded up as in MATLAB
    assert toolbox_frame_offsets([SyncOffsets(2, 5, 2.0), SyncOffsets(1, 6, 2.0)]).tolist() == [3, 1]


@pytest.fixture(scope="module")
def sync_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sync") / "Walking_1_(C1).ofs"
    SyncOffsets(12.0, 7.0, 2.0000000001).save(path)
    return path, path.read_bytes()


@settings(max_examples=100)
@given(data=st.data())
def test_a_damaged_sync_file_is_refused_or_read_whole(sync_file, data):
    """A cut ``.ofs`` is refused (too few numbers) or read as HumanEva distributes it with a
    warning that its last number may be cut; a byte changed is refused or read."""
    path, whole = sync_file
    damage = data.draw(damages(whole))
    outcome = read_damaged(SyncOffsets.load, path, damage, whole)
    if damage.kind == "cut" and outcome is not None:
        assert any("has no line end: read as it is" in message for message in outcome[1]), f"{damage}: not warned"
