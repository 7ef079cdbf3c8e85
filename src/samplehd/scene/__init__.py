"""samplehd.scene."""
