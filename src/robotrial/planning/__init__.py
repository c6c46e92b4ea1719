"""Arm motion planning, the MoveIt role: planners, smoothing, timing (layer 3)."""
