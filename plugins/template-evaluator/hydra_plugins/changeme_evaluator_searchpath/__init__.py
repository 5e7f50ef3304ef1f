# TEMPLATE: rename this folder (changeme_evaluator_searchpath): its name must be unique among
# all installed Hydra plugins, or installing yours silently replaces another's. Do not add
# an __init__.py to hydra_plugins/ itself: it is a namespace package shared by all of them.
"""The Hydra search-path plugin of the changeme evaluator (:mod:`.searchpath`)."""
