"""The body model: the 16-joint skeleton and its pose parameters, forward and inverse kinematics,
the skin mesh and the tracker's model of one subject (lengths in mm, angles in rad)."""
