"""Forward and inverse kinematics over a RobotModel (layer 2)."""
