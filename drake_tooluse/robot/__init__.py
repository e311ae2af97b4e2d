"""What the robot believes: the Baxter model writer, the robot model with a believed tool, the tool-tip IK."""
