"""Sequences to track: the on-disk sequence layout and its reader, calibrations, synthetic
sequences (motion, rendering, realism), HumanEva-I and a user's own recordings."""
