"""Hydra configs of the plugin, found as pkg://mmocap_pycma.conf (Hydra takes a pkg:// path
as available only when it is a package, with an __init__.py)."""
