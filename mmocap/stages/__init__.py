"""The stages of a tracking run: background models, foreground masks, the first pose, frame-by-frame
tracking (with multi-fidelity search and recovery) and its accuracy against ground truth."""
