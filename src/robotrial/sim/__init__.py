"""The MuJoCo world: physics loop, controllers and sensors, the Gazebo role (layer 2)."""
