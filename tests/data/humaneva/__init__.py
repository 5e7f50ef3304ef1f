"""HumanEva-I layout: a tiny synthetic sequence exported to it and read back (the folders
are fixtures of ``conftest.py``; the sizes and the reader are in ``tests/helpers.py``)."""
