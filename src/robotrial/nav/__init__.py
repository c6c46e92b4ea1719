"""Navigation, the move_base role: costmaps, planners, AMCL (layer 3)."""
