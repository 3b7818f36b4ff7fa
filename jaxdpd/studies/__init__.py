"""Studies built on runs: fitting DPD parameters, pathwise gradients, relaxation times."""
