"""The evaluator benchmark, ``mmocap bench``: the Cano paper's Tables 1 and 2 (and Fig. 3)
for this machine (:mod:`.tables`), the silhouette kernel's roofline (:mod:`.roofline`) and
multi-fidelity against exact search (:mod:`.fidelity`); :mod:`.cli` is the command."""
