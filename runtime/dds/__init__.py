"""The Cyclone DDS transport: ROS 2 wire conventions over the cyclonedds wheel."""
