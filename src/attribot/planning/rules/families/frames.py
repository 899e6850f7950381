"""The frames around a reading, read in `attribot.planning.rules.read` and written around any family's
program: a surface scope, a request with an action, ranks and narrowings. Registered for their examples."""

from __future__ import annotations

from attribot.planning.rules.families import FAMILY_REGISTRY, Family

FAMILY_REGISTRY.register("scope")(
    Family(examples=("What's the heaviest thing on the counter?", "Which object is on the floor?"))
)
FAMILY_REGISTRY.register("action")(
    Family(examples=("bring me the lightest cup on the table", "Put the tomato on the counter"))
)
FAMILY_REGISTRY.register("composition")(
    Family(examples=("the second lightest mug", "the heaviest of the two closest objects"))
)
