"""samplehd.catalogue."""
