"""Every LeafSystem of the project (and the trajectory and camera sources), each with its port block."""
