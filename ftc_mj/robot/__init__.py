"""The robot: its MuJoCo model (MJCF or URDF) and the controller's nominal model of it."""
