"""The Hydra search-path plugin of mmocap-pycma (:mod:`.searchpath`)."""
