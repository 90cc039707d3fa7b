"""The seed paper's scenes, its tracer and the workloads replayed from it."""
