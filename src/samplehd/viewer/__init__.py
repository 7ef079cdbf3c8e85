"""samplehd.viewer."""
