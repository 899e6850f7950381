"""What LLM-written programs see: `ImagePatch` and `Robot`. The prompt is generated from these classes.

Host side, to build what a program gets:
    perception = Perception.from_settings(settings)            # detector, vqa, language backends
    robot = Robot(sensors=["camera", "distance"], world=world) # controller chosen for the world
    image = robot.look(perception)                             # ImagePatch of a fresh camera frame
or, for a still image: image = ImagePatch.from_image(path, perception); robot = Robot(sensors=["camera"]).
"""

from attribot.api.errors import ActionFailed, ApiArgumentError, ApiError, MissingSensor, PreconditionError
from attribot.api.patch import ImagePatch
from attribot.api.perception import Perception
from attribot.api.robot import Measurement, Robot, sensor_names

__all__ = [
    "ImagePatch",
    "Robot",
    "Perception",
    "Measurement",
    "sensor_names",
    "ApiError",
    "ApiArgumentError",
    "MissingSensor",
    "PreconditionError",
    "ActionFailed",
]
