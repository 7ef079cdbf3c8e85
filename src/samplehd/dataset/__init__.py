"""samplehd.dataset."""
