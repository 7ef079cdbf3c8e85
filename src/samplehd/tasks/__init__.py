"""samplehd.tasks."""
