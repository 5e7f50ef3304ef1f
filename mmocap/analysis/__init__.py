"""Analysis of finished runs and sweeps: the results store, statistics, Pareto fronts, tables and
figures."""
