"""The planner's collision model: link spheres, environment shapes, batched checks (layer 2)."""
