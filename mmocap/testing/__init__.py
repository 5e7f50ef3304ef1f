"""Conformance suites that plugins reuse in their own tests (see :mod:`.optimizers`), and the
synthetic scene the benchmark and the golden tests share (:mod:`.scene`)."""
