"""HumanEva-I layout: a tiny synthetic sequence exported to it and read back. The sizes of
that export, and how the tests open it (the folders are fixtures of ``conftest.py``)."""
from mmocap.data.humaneva.dataset import HumanEvaDataset
from mmocap.data.humaneva.layout import TOOLBOX_FIRST_FRAME

CAMERAS = ["C1", "BW1"]
FRAMES = 3
LEAD = 4  # the exporter's default mocap lead
LEAD_IN = TOOLBOX_FIRST_FRAME - 1  # images before the sequence in an exported video
FIRST = LEAD + 2 * LEAD_IN  # 0-based mocap frame of the sequence's first frame


def open_he(root, **kwargs):
    return HumanEvaDataset(root, cameras=kwargs.pop("cameras", CAMERAS), **kwargs).open(progress=False)
