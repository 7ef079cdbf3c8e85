"""samplehd.commands."""
