//! ROS map_server I/O: YAML + PGM/PNG.
