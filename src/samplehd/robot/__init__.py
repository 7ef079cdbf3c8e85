"""samplehd.robot."""
