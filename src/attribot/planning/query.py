"""The checks every query passes before a planner reads it: text, valid UTF-8, not empty, not too long.

It imports nothing of the API or the runner, so that reading a query (the rules planner) needs neither.
"""

from __future__ import annotations

import re

from attribot.config import MAX_QUERY_CHARS
from attribot.errors import InputError
from attribot.text import control_characters

__all__ = ["check_query", "is_utf8_text", "asks_for_object"]

# "which ...", "find the ...", "bring the lightest cup ...", "the second cup from the left", "what is the
# heaviest object": the answer is an object. "how far ...", "is the mug heavier ...", "what colour ..." are
# answered with a value, a yes or no, or a text.
_OBJECT_QUERY = re.compile(
    r"^(?:please\s+)?(?:which\b(?!\s+(?:colou?r|kind|type|material|shape|brand|word|number|side|way)\b)|"
    r"(?:find|bring|fetch|get|grab|pick|point|show|locate|select|choose|give|"
    r"hand|take|move|put|push|where)\b|the\b|a\b|an\b|"
    r"(?:what|whats|what's)\s+(?:is|are)\s+the\s+\w+(?:est|most)\b)",
    re.IGNORECASE,
)


def is_utf8_text(text: str) -> bool:
    """False when `text` holds lone surrogates: undecodable bytes of a command line or a file, which no
    JSON file or terminal can take."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def asks_for_object(query: str) -> bool:
    """Whether `query` asks for an object (so that a program returning no object is no answer). Unsure
    phrasings count as not asking: they are left to the program."""
    return bool(_OBJECT_QUERY.match(query.strip()))


def check_query(query: str) -> str:
    """The query with its white space runs made single spaces; an empty or overlong query, or one that holds
    control characters, raises `InputError`."""
    if not isinstance(query, str):
        raise InputError(f"the query must be text, not {type(query).__name__}")
    text = " ".join(query.split())
    if not is_utf8_text(text):
        raise InputError(
            "the query is not valid UTF-8 text (it holds bytes that are no character)",
            "type the question again, or check the terminal's encoding (e.g. LANG=C.UTF-8)",
        )
    if not text:
        raise InputError("the query is empty", 'ask about an object, e.g. "the second dog from the right"')
    controls = control_characters(text)
    if controls:  # "Which object\x1b[2J is ..." was searched for "object 2j"
        raise InputError(
            f"the query holds control characters ({', '.join(controls)}), which are no part of a question",
            "type the question again without them (an escape sequence may have been pasted with it)",
        )
    if len(text) > MAX_QUERY_CHARS:
        raise InputError(
            f"the query is {len(text)} characters long, more than the {MAX_QUERY_CHARS} allowed",
            "ask one short question about one object",
        )
    return text
