"""Markerless multi-camera motion capture: a 16-joint body model fitted, frame after frame, to
the silhouettes that background subtraction finds in calibrated camera images, by a
population-based optimiser (CMA-ES, DE, PSO, APF) that scores candidate poses with a silhouette
evaluator (NumPy, worker processes or OpenCL).

The command line is :mod:`mmocap.cli`; plugins implement the interfaces of :mod:`mmocap.api`
and are found through :mod:`mmocap.registry`."""
