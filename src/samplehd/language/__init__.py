"""samplehd.language."""
