"""samplehd.motion."""
