"""Offscreen rendering: GL backend choice, RGB / depth / segmentation, quality presets."""
