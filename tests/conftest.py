"""Shared fixtures: one tiny synthetic sequence rendered once per test session."""

import logging
import os
from pathlib import Path

import pytest
from hypothesis import settings

from mmocap.data.synthetic import generate
from tests.helpers import TINY

# Property-based tests: the same examples on every run (a failure in CI reproduces here), no
# example database left in the checkout, and no per-example deadline on a shared, noisy machine.
# HYPOTHESIS_PROFILE=explore draws new examples, 1000 per test.
settings.register_profile("mmocap", derandomize=True, database=None, deadline=None)
settings.register_profile("explore", database=None, deadline=None, max_examples=1000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "mmocap"))


@pytest.fixture(scope="session")
def tiny_sequence(tmp_path_factory) -> Path:
    """A 4-frame, 3-camera, 320x240 S1 walking sequence."""
    return generate(tmp_path_factory.mktemp("data") / "S1_walking", progress=False, **TINY)


@pytest.fixture(autouse=True)
def no_logging_into_closed_streams():
    """After each test, drop the log handlers that write into a stream the test closed.

    A run in this process (Hydra's job logging) binds its handler to the ``sys.stdout`` of
    that moment, which is pytest's capture of the test; once the test ends that stream is
    closed, and the next log line of a later test in this process fails with a "Logging
    error" and a traceback on stderr."""
    yield
    for logger in [logging.getLogger(), *logging.Logger.manager.loggerDict.values()]:
        for handler in list(getattr(logger, "handlers", [])):
            stream = getattr(handler, "stream", None)
            if stream is not None and getattr(stream, "closed", False):
                logger.removeHandler(handler)
