"""The sensors attribot's worlds offer: the paper's camera, rangefinder and wrist force sensor, and two it
proposed adding (an infrared thermometer, and a gripper that feels how hard it squeezes)."""

from __future__ import annotations

from attribot.sensors import GRAVITY, Need, Sense, Sensor, State, register_sensor

__all__: list[str] = []

register_sensor(
    Sensor(
        name="camera",
        measures="colour images (and depth where the world has it): what image.find and visual_query look at",
        aliases=("rgb camera", "color camera", "colour camera", "rgb"),
        capability="camera",
    )
)
register_sensor(
    Sensor(
        name="distance",
        measures="an infrared rangefinder: the distance in metres from the robot to the object centred in "
        "front of it (robot.measure_distance)",
        aliases=(
            "distance sensor",
            "proximity sensor",
            "range sensor",
            "rangefinder",
            "range finder",
            "infrared sensor",
            "infrared distance sensor",
            "ir sensor",
            "tof sensor",
            "time of flight sensor",
            "depth sensor",
        ),
        senses=(
            Sense(
                quantity="distance",
                unit="m",
                needs=Need.AIM,
                readings=5,
                resolution=0.003,
                # "near", "close" and "far" alone are places ("the cup near the plate"), not asked-for ends
                more=("/farther/farthest", "/further/furthest", "/more distant/most distant"),
                less=("/closer/closest", "/nearer/nearest"),
                most=False,  # a choice leads with the nearest
                written=("farther", "closer", "farthest", "nearest"),
                nouns=("distance",),
                why="one picture does not tell how far away something is",
                doing="measuring the distance to",
            ),
        ),
        capability="distance",
    )
)
register_sensor(
    Sensor(
        name="force",
        measures="a force sensor at the wrist: the weight of the object held in the gripper, in kilograms "
        "(robot.measure_weight), and so how full a container is (robot.measure_fullness)",
        aliases=(
            "force sensor",
            "force/torque sensor",
            "force torque sensor",
            "force-torque sensor",
            "f/t sensor",
            "ft sensor",
            "wrist force sensor",
            "load cell",
            "weight sensor",
            "scale",
        ),
        senses=(
            Sense(
                quantity="weight",
                unit="kg",
                needs=Need.GRASP,
                readings=10,
                resolution=0.02 / GRAVITY,
                more=("heavy/heavier/heaviest",),
                less=("light/lighter/lightest", "lightweight/more lightweight/most lightweight"),
                nouns=("weight", "mass"),
                why="the camera cannot see how heavy something is",
                doing="weighing",
            ),
            Sense(
                quantity="fullness",
                unit="full",
                needs=Need.GRASP,
                readings=10,
                more=("full/fuller/fullest", "filled"),
                less=("empty/emptier/emptiest",),
                states=(State("full", 0.5, ">"), State("filled", 0.5, ">"), State("empty", 0.5, "<")),
                nouns=("fullness", "fill level", "level"),
                why="an empty and a full container look the same",
                doing="weighing",
                digits=0,
                scale=100.0,
                suffix="% full",
            ),
        ),
        capability="force",
    )
)

_TEMPERATURE_DOC = """Returns the temperature in degrees Celsius of the object the camera is centred on, read
with the infrared thermometer on the head, which reads whatever its beam hits (like the distance sensor): call
robot.focus_on_patch(patch) first, on this object, and again after the robot has moved. The camera
cannot see temperature: a hot mug looks like a cold one. Room temperature is about 20 to 24.

>>> # which mug is hot?
>>> def execute_command(image, robot):
>>>     hottest, hottest_c = None, 0.0
>>>     for mug in image.find("mug"):
>>>         robot.focus_on_patch(mug)
>>>         celsius = robot.measure_temperature(mug)
>>>         if hottest is None or celsius > hottest_c:
>>>             hottest, hottest_c = mug, celsius
>>>     return hottest"""

register_sensor(
    Sensor(
        name="temperature",
        measures="an infrared thermometer on the head, along the camera's axis: the temperature in degrees "
        "Celsius of the object the camera is centred on (robot.measure_temperature)",
        aliases=(
            "thermometer",
            "infrared thermometer",
            "ir thermometer",
            "temperature sensor",
            "infrared temperature sensor",
            "ir temperature sensor",
            "thermal sensor",
            "heat sensor",
            "pyrometer",
        ),
        senses=(
            Sense(
                quantity="temperature",
                unit="°C",
                needs=Need.AIM,
                doc=_TEMPERATURE_DOC,
                readings=5,
                resolution=0.1,
                more=("hot/hotter/hottest", "warm/warmer/warmest", "boiling"),
                less=("cold/colder/coldest", "cool/cooler/coolest", "chilled"),
                states=(
                    State("hot", 40.0, ">="),
                    State("boiling", 90.0, ">="),
                    State("warm", 30.0, ">="),
                    State("cold", 12.0, "<="),
                    State("chilled", 12.0, "<="),
                    State("cool", 18.0, "<="),
                ),
                grades=("hot", "warm", "cold", "cool"),
                ungraded="room",
                nouns=("temperature",),
                why="the camera cannot see how hot something is",
                doing="taking the temperature of",
                digits=1,
            ),
        ),
    )
)

_STIFFNESS_DOC = """Returns how hard the object in `patch` is: its stiffness in newtons per millimetre of
gripper closure, measured by squeezing it with the gripper and reading the force against the closure. Low
is soft (a foam ball or a sponge, under 1), high is hard (an apple, a mug, over 5). The object must be
held: call robot.go_to_object(patch) and robot.pick_up(patch) first, and robot.put_down() afterwards.

>>> # the softest ball
>>> def execute_command(image, robot):
>>>     softest, softest_n_per_mm = None, 0.0
>>>     for ball in image.find("ball"):
>>>         robot.go_to_object(ball)
>>>         robot.pick_up(ball)
>>>         stiffness = robot.measure_stiffness(ball)
>>>         robot.put_down()
>>>         if softest is None or stiffness < softest_n_per_mm:
>>>             softest, softest_n_per_mm = ball, stiffness
>>>     return softest"""

register_sensor(
    Sensor(
        name="grip",
        measures="a gripper that reads its closure and squeezing force: how hard the held object is, in "
        "newtons per millimetre (robot.measure_stiffness)",
        aliases=(
            "gripper force sensor",
            "grip force sensor",
            "grip sensor",
            "gripper sensor",
            "tactile sensor",
            "touch sensor",
            "squeeze sensor",
            "softness sensor",
            "stiffness sensor",
        ),
        senses=(
            Sense(
                quantity="stiffness",
                unit="N/mm",
                needs=Need.GRASP,
                doc=_STIFFNESS_DOC,
                readings=2,
                resolution=0.02,
                relative=0.05,
                more=(
                    "hard/harder/hardest",
                    "firm/firmer/firmest",
                    "stiff/stiffer/stiffest",
                    "rigid/more rigid/most rigid",
                ),
                less=(
                    "soft/softer/softest",
                    "squishy/squishier/squishiest",
                    "squashy/squashier/squashiest",
                    "spongy",
                ),  # fmt: skip
                states=(
                    State("hard", 5.0, ">="),
                    State("rigid", 5.0, ">="),
                    State("firm", 1.0, ">="),
                    State("stiff", 1.0, ">="),
                    State("soft", 1.0, "<"),
                    State("squishy", 1.0, "<"),
                    State("squashy", 1.0, "<"),
                    State("spongy", 1.0, "<"),
                ),
                grades=("hard", "firm", "soft"),
                nouns=("stiffness", "softness", "hardness", "firmness"),
                why="the camera cannot feel how hard something is",
                doing="squeezing",
                digits=2,
            ),
        ),
    )
)
