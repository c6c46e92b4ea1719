"""Experiments and reports: headless trials that score the platform (layer 5)."""
