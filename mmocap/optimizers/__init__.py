"""The built-in batch ask/tell minimisers (:class:`mmocap.api.Optimizer`): CMA-ES, differential
evolution, particle swarm and the annealed particle filters, on their shared machinery."""
