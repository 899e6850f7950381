"""The embedded MuJoCo household world: catalog, scenes, robot, sensors and rendering."""
