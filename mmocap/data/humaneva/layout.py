"""HumanEva-I's layout under ``root``, as the dataset is distributed::

    S1..S4/Calibration_Data/<cam>.cal              C1, C2, C3 (colour), BW1..BW4 (greyscale)
    S*/Image_Data/<Action>_<Trial>_(<cam>).avi     60 Hz video, or a folder of that name
                                                   holding numbered image files
    S*/Sync_Data/<Action>_<Trial>_(<cam>).ofs      IM_ST MC_ST MC_SC
    S*/Mocap_Data/<Action>_<Trial>.mat             120 Hz markers (withheld for trial 2)
    Background/Background_<k>_(<cam>).avi          empty-scene videos, k = 1, 2, ...

Actions: Walking, Jog, ThrowCatch, Gestures, Box, Combo; trials 1..3 (trial 3 has no video).

Toolbox frames: the dataset's MATLAB toolbox numbers a trial's synchronised 60 Hz frames from
1 (:func:`mmocap.data.humaneva.synchronisation.toolbox_frame_offsets`), and starts every
sequence with video at frame :data:`TOOLBOX_FIRST_FRAME` (6).  Its Train, Validation and Test
partitions (:data:`PARTITIONS`) are ranges of these frames.
"""

from __future__ import annotations

SUBJECTS = ("S1", "S2", "S3", "S4")
ACTIONS = ("Walking", "Jog", "ThrowCatch", "Gestures", "Box", "Combo")
TRIALS = (1, 2, 3)
CAMERAS = ("C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4")
# The toolbox's first frame of every sequence with video (1-based toolbox frame): its XviD
# videos repeat their first image, so frames 1-5 are not used (toolbox read-me, v0.8).
TOOLBOX_FIRST_FRAME = 6
SPLITS = ("train", "validation", "test")
# The partitions of HumanEva-I in the dataset's MATLAB toolbox (Sigal, Balan and Black, support
# code v1.1, @he_dataset/he_dataset.m, where validation is called "Validate"; the trial 1 ranges
# agree with facebookresearch/VideoPose3D, data/prepare_data_humaneva.py): (subject, action,
# trial) -> split -> (first, last) toolbox frame, both included (1-based 60 Hz frames, numbered
# as :func:`mmocap.data.humaneva.synchronisation.toolbox_frame_offsets` describes).  The
# toolbox also puts trial 3 (mocap only, no video) into Train as a whole; having no images to
# read, it is not listed.
PARTITIONS = {
    ("S1", "Walking", 1): {"validation": (6, 590), "train": (591, 1203)},
    ("S1", "Walking", 2): {"test": (6, 1004)},
    ("S1", "Jog", 1): {"validation": (6, 367), "train": (368, 740)},
    ("S1", "Jog", 2): {"test": (6, 874)},
    ("S1", "ThrowCatch", 1): {"validation": (6, 473), "train": (474, 945)},
    ("S1", "ThrowCatch", 2): {"test": (6, 951)},
    ("S1", "Gestures", 1): {"validation": (6, 395), "train": (396, 801)},
    ("S1", "Gestures", 2): {"test": (6, 1070)},
    ("S1", "Box", 1): {"validation": (6, 385), "train": (386, 789)},
    ("S1", "Box", 2): {"test": (6, 606)},
    ("S1", "Combo", 2): {"test": (6, 2602)},
    ("S2", "Walking", 1): {"validation": (6, 438), "train": (439, 876)},
    ("S2", "Walking", 2): {"test": (6, 1093)},
    ("S2", "Jog", 1): {"validation": (6, 398), "train": (399, 795)},
    ("S2", "Jog", 2): {"test": (6, 727)},
    ("S2", "ThrowCatch", 1): {"validation": (6, 550), "train": (551, 1128)},
    ("S2", "ThrowCatch", 2): {"test": (6, 1399)},
    ("S2", "Gestures", 1): {"validation": (6, 500), "train": (501, 901)},
    ("S2", "Gestures", 2): {"test": (6, 1062)},
    ("S2", "Box", 1): {"validation": (6, 382), "train": (383, 734)},
    ("S2", "Box", 2): {"test": (6, 989)},
    ("S2", "Combo", 2): {"test": (6, 2054)},
    ("S3", "Walking", 1): {"validation": (6, 448), "train": (449, 939)},
    ("S3", "Walking", 2): {"test": (6, 805)},
    ("S3", "Jog", 1): {"validation": (6, 401), "train": (402, 842)},
    ("S3", "Jog", 2): {"test": (6, 864)},
    ("S3", "ThrowCatch", 1): {"validation": (6, 493), "train": (494, 1027)},
    ("S3", "ThrowCatch", 2): {"test": (6, 1000)},
    ("S3", "Gestures", 1): {"validation": (6, 533), "train": (534, 1102)},
    ("S3", "Gestures", 2): {"test": (6, 553)},
    ("S3", "Box", 1): {"validation": (6, 512), "train": (513, 1021)},
    ("S3", "Box", 2): {"test": (6, 753)},
    ("S3", "Combo", 2): {"test": (6, 1798)},
    ("S4", "Walking", 2): {"test": (6, 667)},
    ("S4", "Jog", 2): {"test": (6, 590)},
    ("S4", "ThrowCatch", 2): {"test": (6, 773)},
    ("S4", "Gestures", 2): {"test": (6, 459)},
    ("S4", "Box", 2): {"test": (6, 574)},
    ("S4", "Combo", 2): {"test": (6, 1102)},
}


def is_colour(camera: str) -> bool:
    """HumanEva-I's C cameras are colour, its BW cameras greyscale."""
    return not camera.upper().startswith("BW")
