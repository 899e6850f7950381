"""Controllers shared by the simulator and real robots: PID, KLT tracking, visual servoing.

`servo.ServoController` acts on perception alone through its collaborators: `focus` (centring the camera,
a state machine), `locate`, `reach`, `manipulate` and `drive`, sharing a `plant.Plant`; `world.ServoWorld`
is all it uses of a world, `tuning.ServoTuning` all its numbers."""
