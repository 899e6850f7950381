"""A lab's words for the built-in senses: the force sensor's weight said "hefty/heftier/heftiest" too, and the
rangefinder's distance "/nigher/nighest" too. Importing this module registers them (as a module named in
`ATTRIBOT_PLUGINS` would), so import it before the planner: the planner reads the records as it loads."""

from __future__ import annotations

from dataclasses import replace

from attribot.sensors import SENSORS, register_sensor

__all__ = ["EXTRA_WORDS"]

EXTRA_WORDS = {
    # sensor: (quantity, asks for more, the entry added to the sense's more or less)
    "force": ("weight", True, "hefty/heftier/heftiest"),
    "distance": ("distance", False, "/nigher/nighest"),
}


def _with_words(name: str, quantity: str, more: bool, entry: str) -> None:
    """Register the sensor `name` again, its sense of `quantity` with `entry` among its words."""
    sensor = SENSORS.unregister(name)
    sense = next(s for s in sensor.senses if s.quantity == quantity)
    worded = replace(sense, more=(*sense.more, entry)) if more else replace(sense, less=(*sense.less, entry))
    register_sensor(replace(sensor, senses=tuple(worded if s is sense else s for s in sensor.senses)))


for _name, (_quantity, _more, _entry) in EXTRA_WORDS.items():
    _with_words(_name, _quantity, _more, _entry)
