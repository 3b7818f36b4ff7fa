"""Output files: H5MD trajectories and observables, checkpoints."""
