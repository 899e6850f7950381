"""Every gain, tolerance and timing of the servo controller, in one record.

Seconds are sim seconds in the simulator and wall seconds on a robot; the controller steps the world by
them and never sleeps. Pixels are the camera's, metres and radians are the robot's. Change one for a
whole controller with `ServoController(world, tuning=ServoTuning(tol_px=2.0))`.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ServoTuning"]


@dataclass(frozen=True)
class ServoTuning:
    """The servo's numbers, by what they tune.

    Centring the camera on a target (`FocusLoop`): control_s: time per control step; tol_px: the
    centring tolerance; max_tol_px: the most it widens to when the box is found by detection in every frame
    and the detections jitter (their spread sets it); max_steps: the step budget of one focus; kp / ki: PID
    gains on the angular error (radians of head command per radian of error per step); max_step_rad: the
    largest head correction in one step; turn_kp / turn_ki / max_turn: the PID that turns the base (rad/s
    per radian of error) on a robot without a camera head; max_misses: frames in a row a flaky detector may
    miss the object, when it is found by detection rather than tracked, while its box is carried along by
    the camera's own measured motion.

    Looking again (`Locator`): nudge_rad / nudge_settle_s: how far the head turns for each further view
    when the detector misses the object, and the wait after it; side_look_settle_s: the wait after turning
    a third of the view aside; look_back_settle_s: after turning back; back_off_m: how far the base backs
    off to look once more when the object is missed from where it stands at every turn.

    Driving (`Driver`): drive_speed: the base's top speed, m/s; drive_kp / drive_ki: the PID per axis on
    the odometry position error (m/s per metre); yaw_kp / yaw_ki / max_yaw_rate: the heading's PID (rad/s
    per radian); waypoint_tol: how near an intermediate waypoint counts as passed; yaw_tol: the heading
    tolerance at the goal; stall_s: how long the base may not move before it is blocked (a base stalled
    within stall_arrive_m of its goal has come as near as it can, against what stands there, and has
    arrived: the perception that follows corrects the rest); drive_timeout_s:
    the longest drive; straight_speed: the speed of straight drives (pushes, backing off); stop_s: the wait
    for the base to stop.

    Ranging (`Locator`): range_readings / range_step_s: rangefinder readings taken to locate an object
    without depth and the time between them (the median of those it got counts; a dropout is not one).

    Reaching (`Reacher`): arrive_tol: how close (metres) the arm's line must pass to the object;
    align_tries: base corrections at the goal; stand_tries: places to stand tried when the camera loses the
    object at one.

    Manipulating (`Manipulator`): lift_clear: how high a picked object is raised (less under a shelf
    board); push_m: how far a push drives on after the base meets the object; arm_move_s: the wait for the
    lift or telescope to reach a new command; grip_lower_s: to lower to the grip height; extend_s: to reach
    out to the object; lift_load_s: to lift what was grasped; place_lower_s: to lower onto a surface;
    clear_s: to rise off what was let go. load_readings / load_step_s: force readings averaged for one load
    and the time between them; load_min_n: the smallest load change that counts as holding something;
    load_sigmas: standard errors of the difference within which a load change is noise; load_max_noise_n:
    a sensor noisier than this leaves the verdict to the gripper; closed_gripper_m: a finger gap below which
    the fingers met (the object fell out).

    Putting on a large receptacle (`Manipulator.put_on`): large_top_m2: the area of flat top (as depth
    sees it) from which a receptacle is furniture whose top takes the object at a free spot near the robot
    (smaller ones, a plate, a bowl, take it at their middle); top_clear_m: how far above a top depth must
    see something to count it as standing there (more than the depth's noise); place_clear_m: the
    clearance kept around the object from what stands on the top and from its edges; spot_tries: free
    spots tried, nearest first, for a place to stand within the arm's reach; place_tol: how close the arm's
    line must pass to the spot; lower_step_m / lower_step_s / lower_below_m: the guarded descent onto the
    top, step by step while the wrist's load is watched, down to this far below where depth says the
    object meets it.
    """

    control_s: float = 0.05
    tol_px: float = 1.5
    max_tol_px: float = 6.0
    max_steps: int = 80
    kp: float = 0.8
    ki: float = 0.4
    max_step_rad: float = 0.15
    turn_kp: float = 3.0
    turn_ki: float = 0.5
    max_turn: float = 1.0
    max_misses: int = 3

    nudge_rad: float = 0.02
    nudge_settle_s: float = 0.15
    side_look_settle_s: float = 0.4
    look_back_settle_s: float = 0.3
    back_off_m: float = 0.3

    range_readings: int = 5
    range_step_s: float = 0.02

    drive_speed: float = 0.5
    drive_kp: float = 2.0
    drive_ki: float = 0.3
    yaw_kp: float = 2.5
    yaw_ki: float = 0.2
    max_yaw_rate: float = 1.5
    waypoint_tol: float = 0.08
    yaw_tol: float = 0.01
    stall_s: float = 1.5
    stall_arrive_m: float = 0.03
    drive_timeout_s: float = 60.0
    straight_speed: float = 0.2
    stop_s: float = 0.3

    arrive_tol: float = 0.012
    align_tries: int = 4
    stand_tries: int = 3

    lift_clear: float = 0.08
    push_m: float = 0.15
    arm_move_s: float = 0.8
    grip_lower_s: float = 0.6
    extend_s: float = 1.0
    lift_load_s: float = 1.5
    place_lower_s: float = 1.2
    clear_s: float = 0.6
    load_readings: int = 8
    load_step_s: float = 0.02
    load_min_n: float = 0.004
    load_sigmas: float = 3.0
    load_max_noise_n: float = 0.05
    closed_gripper_m: float = 0.0003

    large_top_m2: float = 0.12
    top_clear_m: float = 0.004
    place_clear_m: float = 0.03
    spot_tries: int = 12
    place_tol: float = 0.02
    lower_step_m: float = 0.005
    lower_step_s: float = 0.15
    lower_below_m: float = 0.03
