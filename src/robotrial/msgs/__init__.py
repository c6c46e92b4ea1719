"""ROS message types as dataclasses, with rosbridge JSON and CBOR conversion (layer 0)."""
