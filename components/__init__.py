"""twmr.components: the paper's blocks (plant, slip, trajectory, asmc, smc, motor)."""
