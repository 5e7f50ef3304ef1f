"""HumanEva-I's ground truth: the ``.mat`` marker files, and the map from their labels to the
body model's markers.

The ``.mat`` file holds ``Markers`` (mocap frames, labels, 3) in mm, missing markers being
stored as zeros (read as NaN), and the labels under ``ParameterGroup`` POINT/LABELS.
``marker_map`` (data in ``conf/dataset/humaneva.yaml``) gives, for each of the body model's
markers (:data:`mmocap.body.model.MARKER_NAMES`), the mocap labels whose centroid stands for
it.  The marker error then measures the distance between the model's skin points and those
physical markers: a systematic placement offset (the model's point is not where the marker
was stuck) adds to the tracking error, so figures are comparable between runs on HumanEva-I,
not equal to those of methods scored on HumanEva's virtual joint centres.

Markers at a fractional mocap index are interpolated linearly between the two nearest mocap
frames (NaN if either is missing, :func:`sample_mocap`).
"""

from __future__ import annotations

import faulthandler
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import numpy as np
import scipy.io
from omegaconf import OmegaConf

from mmocap import config
from mmocap.body.model import MARKER_NAMES
from mmocap.errors import ConfigError, DataError

MOCAP_RATE_HZ = 120.0


def default_marker_map() -> dict[str, list[str]]:
    """The marker map of ``conf/dataset/humaneva.yaml``."""
    return OmegaConf.to_container(config.load("dataset/humaneva.yaml").marker_map)  # type: ignore[return-value]  # a mapping of lists


def _as_list(x) -> list:
    """A value of ``loadmat(simplify_cells=True)`` as a list (single items come unwrapped)."""
    if isinstance(x, list):
        return x
    if isinstance(x, np.ndarray):
        return list(x.ravel())
    return [x]


def _load_mat_here(path: str) -> dict:
    """``scipy.io.loadmat`` in the child process of :func:`load_mat`, which dies quietly if it
    crashes (no fault handler's traceback: the parent says what happened)."""
    faulthandler.disable()
    return scipy.io.loadmat(path, simplify_cells=True)


def load_mat(path: Path) -> dict:
    """``scipy.io.loadmat(path, simplify_cells=True)``, run in a child process: scipy's reader
    can crash on a damaged file (a segmentation fault, which ends the process that runs it),
    and such a file must be refused with one line like any other. Any failure is a DataError
    naming the file."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as child:
        try:
            return child.submit(_load_mat_here, str(path)).result()
        except BrokenProcessPool:
            problem = "scipy's reader crashed on it"
        except Exception as exc:  # scipy raises many types for a damaged file
            problem = " ".join(str(exc).split())
    raise DataError(f"cannot read mocap file {path}: {problem}; is it damaged or cut short? download it again")


def read_mocap(path: Path) -> tuple[list[str], np.ndarray]:
    """A HumanEva ``.mat`` marker file -> labels (L,) and (mocap frames, L, 3) mm, NaN = missing.

    Labels lose any ``subject:`` prefix; a marker stored as (0, 0, 0) is missing. A damaged
    or cut file is a DataError naming it (:func:`load_mat`).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"mocap file not found: {path}")
    mat = load_mat(path)
    markers = np.asarray(mat.get("Markers", np.empty(0)), dtype=np.float64)
    if markers.ndim == 2 and markers.shape[1] == 3:  # a single label comes squeezed
        markers = markers[:, None, :]
    if markers.ndim != 3 or markers.shape[2] != 3 or markers.shape[0] < 1:
        raise DataError(f"mocap file {path}: 'Markers' must be (frames, markers, 3), got shape {markers.shape}")
    labels = None
    for group in _as_list(mat.get("ParameterGroup", [])):
        if isinstance(group, dict) and group.get("name") == "POINT":
            for param in _as_list(group.get("Parameter", [])):
                if isinstance(param, dict) and param.get("name") == "LABELS":
                    labels = [str(x).split(":")[-1].strip() for x in _as_list(param.get("data"))]
    if labels is None:
        raise DataError(f"mocap file {path} has no ParameterGroup POINT/LABELS")
    if len(labels) != markers.shape[1]:
        raise DataError(f"mocap file {path}: {len(labels)} labels for {markers.shape[1]} markers")
    markers[np.all(markers == 0, axis=2)] = np.nan
    return labels, markers


def _cell(items) -> np.ndarray:
    cell = np.empty((1, len(items)), dtype=object)
    for k, item in enumerate(items):
        cell[0, k] = item
    return cell


def _struct_array(records: list[dict]) -> np.ndarray:
    array = np.empty((1, len(records)), dtype=[(key, object) for key in records[0]])
    for k, record in enumerate(records):
        for key, value in record.items():
            array[0, k][key] = value
    return array


def write_mocap(path: Path, labels, markers: np.ndarray, rate_hz: float = MOCAP_RATE_HZ) -> None:
    """(mocap frames, L, 3) mm -> a ``.mat`` file in the structure of HumanEva's: ``Markers``
    with missing (NaN) markers as zeros, and ``ParameterGroup`` POINT with LABELS, RATE,
    UNITS and USED."""
    point = [
        {"name": _cell(["LABELS"]), "data": _cell(list(labels))},
        {"name": _cell(["RATE"]), "data": float(rate_hz)},
        {"name": _cell(["UNITS"]), "data": _cell(["mm"])},
        {"name": _cell(["USED"]), "data": float(len(labels))},
    ]
    groups = _struct_array([{"name": _cell(["POINT"]), "Parameter": _struct_array(point)}])  # type: ignore[arg-type]
    scipy.io.savemat(str(path), {"Markers": np.nan_to_num(markers, nan=0.0), "ParameterGroup": groups})


def check_marker_map(marker_map: dict) -> dict[str, list[str]]:
    """Every model marker mapped to a non-empty list of labels, no label used twice."""
    marker_map = {str(k): [str(v)] if isinstance(v, str) else [str(x) for x in v] for k, v in dict(marker_map).items()}
    unknown = sorted(set(marker_map) - set(MARKER_NAMES))
    missing = [m for m in MARKER_NAMES if not marker_map.get(m)]
    if unknown or missing:
        raise ConfigError(
            f"dataset.marker_map must give labels for exactly the markers "
            f"{', '.join(MARKER_NAMES)}; unknown: {unknown}, without labels: {missing}"
        )
    labels = [label for names in marker_map.values() for label in names]
    if len(labels) != len(set(labels)):
        raise ConfigError("dataset.marker_map uses a mocap label for two markers")
    return marker_map


def model_markers(labels: list[str], markers: np.ndarray, marker_map: dict, path: Path) -> np.ndarray:
    """(mocap frames, L, 3) labelled markers -> (mocap frames, 15, 3) body-model markers, each
    the centroid of its mapped labels (NaN where any of them is missing)."""
    column = {label: k for k, label in enumerate(labels)}
    out = np.empty((markers.shape[0], len(MARKER_NAMES), 3))
    for m, name in enumerate(MARKER_NAMES):
        absent = [label for label in marker_map[name] if label not in column]
        if absent:
            raise DataError(
                f"mocap file {path} has no marker labelled {', '.join(absent)} "
                f"(mapped to '{name}' by dataset.marker_map)"
            )
        out[:, m] = markers[:, [column[label] for label in marker_map[name]]].mean(axis=1)
    return out


def sample_mocap(markers: np.ndarray, mocap_index) -> np.ndarray:
    """(mocap frames, M, 3) at 1-based fractional indices (n,) -> (n, M, 3), interpolated
    linearly; NaN outside the recording or where a neighbour is missing."""
    position = np.asarray(mocap_index, float) - 1.0
    low = np.floor(position).astype(int)
    weight = position - low
    high = low + (weight > 0)
    inside = (low >= 0) & (high < len(markers))
    out = np.full((len(position),) + markers.shape[1:], np.nan)
    w = weight[inside, None, None]
    out[inside] = (1 - w) * markers[low[inside]] + w * markers[high[inside]]
    return out
