"""samplehd.bench."""
