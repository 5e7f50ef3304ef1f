"""Conformance suites that plugins reuse in their own tests (see :mod:`.optimizers`)."""
