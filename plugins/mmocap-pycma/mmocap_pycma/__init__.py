"""mmocap optimiser plugin around pycma, the reference CMA-ES implementation."""
