"""The silhouette fitness of candidate poses (:class:`mmocap.api.Evaluator`): the rule, a naive
reference, and the NumPy, multi-process and OpenCL backends."""
