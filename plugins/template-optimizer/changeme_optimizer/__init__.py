# TEMPLATE: rename this folder (the package changeme_optimizer) and describe your optimiser.
"""mmocap optimiser plugin (template): random local search as ``optimizer=changeme-rls``."""
