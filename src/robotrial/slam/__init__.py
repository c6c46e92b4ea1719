"""Occupancy-grid SLAM: scan matching and particle-filter mapping (layer 3)."""
