"""A user's own multi-camera recording.

- :mod:`~mmocap.data.recording.reader`: the folder layout, its reader (the Hydra component of
  ``conf/dataset/recording.yaml``) and a writer;
- :mod:`~mmocap.data.recording.commands`: ``mmocap check-recording`` and ``mmocap to-recording``,
  which open a recording as a tracking run would (a job: it uses the stages).
"""
