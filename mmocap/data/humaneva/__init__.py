"""HumanEva-I (Sigal et al. 2010): a reader of the dataset's own layout, and an exporter that
writes a synthetic sequence in that layout.

- :mod:`~mmocap.data.humaneva.layout`: the folders and names of the dataset, and its toolbox's
  partitions;
- :mod:`~mmocap.data.humaneva.synchronisation`: the ``.ofs`` files and the toolbox's frame numbers;
- :mod:`~mmocap.data.humaneva.frames`: a camera's images, from a video or a folder of image files;
- :mod:`~mmocap.data.humaneva.mocap`: the ``.mat`` marker files and the map to the body model's markers;
- :mod:`~mmocap.data.humaneva.dataset`: one trial opened for tracking (the Hydra component);
- :mod:`~mmocap.data.humaneva.export`: a synthetic sequence written in the dataset's layout.
"""
