"""samplehd.envs."""
