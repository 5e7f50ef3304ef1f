# TEMPLATE: nothing to rename. This file makes conf/ a package, which Hydra's pkg:// search
# path (pkg://changeme_evaluator.conf) expects.
