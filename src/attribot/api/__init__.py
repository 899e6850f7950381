"""What LLM-written programs see: `ImagePatch` and `Robot`. The prompt is generated from these classes.

Host side, to build what a program gets:
    perception = Perception.from_settings(settings)            # detector, vqa, language backends
    robot = Robot(sensors=["camera", "distance"], world=world) # controller chosen for the world
    image = robot.look(perception)                             # ImagePatch of a fresh camera frame
or, for a still image: image = ImagePatch.from_image(path, perception); robot = Robot(sensors=["camera"]).
"""

from attribot.api.patch import ImagePatch
from attribot.api.robot import Measurement, Robot, sensor_names
from attribot.skills.errors import ActionFailed, ApiArgumentError, ApiError, MissingSensor, PreconditionError
from attribot.skills.perception import Perception

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
