# TEMPLATE: rename this folder (the package changeme_evaluator) and describe your backend.
"""mmocap evaluator plugin (template): the numpy backend in chunks as ``evaluator=changeme-chunked``."""
