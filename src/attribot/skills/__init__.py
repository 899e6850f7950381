"""The robot's skills, one layer under the API programs see: the robot session (its state, readings and
actions, `robot_session.RobotSession`), the host side of a patch (`sighting.Sighting`), and the
error-catching mechanisms (`safeguards`: looking again, looking harder, verifying actions, measuring again,
confidence, reset). They act on sightings, controller targets and detections, and know nothing of
`attribot.api`, which puts the paper's `ImagePatch` and `Robot` in front of them."""
