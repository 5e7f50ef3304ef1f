"""What a tracking run writes into its folder (the names: :mod:`mmocap.run_folder`): the motion
exports, the convergence traces, and every picture of the run (overlays, the error plot, the
skeleton pictures, the videos)."""
