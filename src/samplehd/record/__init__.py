"""samplehd.record."""
