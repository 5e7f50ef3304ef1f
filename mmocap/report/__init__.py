"""Reports made after the runs: the tables of a results store, run summaries, statistics, the
papers' tables and figures, IOHanalyzer traces and the foreground quality."""
