"""The robot side of a trial: what decides what the robot does (layer 4, beside `ros/`).

A real robot knows only what its sensors tell it, the map it built and the task it was
given in words. This package is that robot: perception (objects from the RGB-D head
camera, `perception`; the arm's collision scene as voxels, `voxels`), skills that each
end in success or a named failure (`skills`: map, navigate, look, search, pick, place)
and the task that strings them (`task`). It runs as nodes on the bus (`robot.Robot`
with the SLAM and navigation nodes it starts) and listens only to sensor topics:

- `/scan`, `/odom`, `/tf`, `/tf_static`, `/joint_states`: the LiDAR cut to a plane, wheel
  odometry, frames, the joints (fingers included);
- `/head_camera/image_raw`, `/head_depth/depth/image_raw` and their `camera_info`: the
  head's RGB-D pair, one frame per call of its `/NAME/capture` service;
- `/map`: the map its own SLAM built.

It commands `/cmd_vel`, `/robotrial/joint_reference`, `/gripper/command`,
`/move_base_simple/goal` and `/initialpose`. It imports algorithms (`planning/`, `nav/`,
`slam/`, `kinematics/`, `collision/`), the bus and the robot's own description, and
never `sim/` or a World: where objects and furniture stand is for the world side
(`trials/`) to score against, never for the robot to read.
"""
