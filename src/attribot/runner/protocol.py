"""The sandbox's pipe protocol, one definition for both ends: JSON objects, one per line.

The worker runs as `python -I -S -B worker.py` and imports this file as its sibling module `protocol`;
the host imports it as `attribot.runner.protocol`. So it imports nothing at all (the worker may load no
site-packages), and its names are the only spelling of the wire's keys and kinds.

A run: the worker sends READY when started; the host sends RUN (the compiled program, entry point,
arguments, limits and API classes); the worker answers GO when its clocks start, then any number of CALL
(each answered by the host with RETURN, ACTION_FAILED or API_ERROR, or STOP when the host ends the run)
and OUT (printed text, not answered), and ends with DONE (the entry point's value) or FAILED (a
structured error).
"""

__all__ = [
    "PROGRAM_FILENAME",
    "KIND",
    "Kind",
    "Key",
    "TAG_HANDLE",
    "TAG_TUPLE",
    "TAG_DICT",
    "TAG_SET",
    "WireLimits",
]

PROGRAM_FILENAME = "<program>"
"""The file name compiled into the program's code: the worker finds the program's lines by it."""

KIND = "t"
"""The key of every message's kind."""


class Kind:
    """The kind of a message (the value under `KIND`)."""

    # worker -> host
    READY = "ready"  # started, waiting for the program
    GO = "go"  # has the program; its clocks run from now
    CALL = "call"  # an API call: HANDLE, METHOD, ARGS, KWARGS, LINE, and at times RECEIVER
    OUT = "out"  # printed text: TEXT
    DONE = "done"  # the entry point returned VALUE
    FAILED = "error"  # the program failed: CATEGORY, MESSAGE, LINE
    # host -> worker
    RUN = "run"  # CODE, ENTRY, ARGS, LIMITS, CLASSES, CONSTRUCTORS, FUNCTIONS
    RETURN = "ret"  # the call's VALUE
    API_ERROR = "err"  # the call failed: CATEGORY, MESSAGE (raised in the program as a stop)
    # the action or measurement ran and failed in the world: MESSAGE (raised in the program as the
    # catchable `ActionFailed`)
    ACTION_FAILED = "fail"
    STOP = "stop"  # the host ends the run: CATEGORY, MESSAGE


class Key:
    """The keys of a message's fields."""

    HANDLE = "h"  # an API object the program holds (an int the host chose)
    METHOD = "m"
    ARGS = "a"
    KWARGS = "k"
    LINE = "l"  # the program's line, or None
    # the object a borrowed method was called on (`book_patch.measure_weight("book")`: the patch), or, when a
    # method of a class with bare functions is given an object's name, the object of a borrowing class the
    # program last called a method of (what it looked at); told to the host method named by PROGRAM_CALLED_ON
    RECEIVER = "r"
    VALUE = "v"
    TEXT = "s"
    CATEGORY = "c"
    MESSAGE = "m"  # never in the same message as METHOD
    CODE = "code"  # base64 of the marshalled code object
    ENTRY = "entry"
    LIMITS = "limits"  # WireLimits.to_wire()
    CLASSES = "classes"  # class name -> its API method names
    # class name -> [handle of the argument object that serves `ClassName(...)` in the program, the host
    # method that does] (the paper's dialect: `ImagePatch(image)`, `Robot(sensors=[...])`)
    CONSTRUCTORS = "ctors"
    # class name -> {FN_METHODS: {method: whether it takes one object}, FN_ON: {class name: [methods]}}:
    # methods a program may also call as bare functions, and on objects of the FN_ON classes (the paper
    # authors' prompt: `go_to_object("book")`, `book_patch.measure_weight("book")`), bound to the
    # program's one object of the class
    FUNCTIONS = "fns"
    FN_METHODS = "m"
    FN_ON = "on"
    # an API object handed to the program the first time: {TAG_HANDLE: h, STUB_CLASS: ..., STUB_ATTRS: ...}
    STUB_CLASS = "c"
    STUB_ATTRS = "a"


# values that JSON has no type for, as one-key objects
TAG_HANDLE = "$h"
TAG_TUPLE = "$t"
TAG_DICT = "$d"
TAG_SET = "$s"


class WireLimits:
    """What one program may use, as it crosses the pipe (the fields of `attribot.runner.records.Limits`,
    which validates them on the host)."""

    FIELDS = (
        "wall_s",
        "cpu_s",
        "memory_mb",
        "max_output_chars",
        "max_api_calls",
        "max_recursion",
        "max_int_bits",
        "max_sequence",
        "max_message_bytes",
        "max_source_chars",
    )
    __slots__ = FIELDS

    def __init__(
        self,
        wall_s: float,
        cpu_s: float,
        memory_mb: int,
        max_output_chars: int,
        max_api_calls: int,
        max_recursion: int,
        max_int_bits: int,
        max_sequence: int,
        max_message_bytes: int,
        max_source_chars: int,
    ) -> None:
        self.wall_s = float(wall_s)
        self.cpu_s = float(cpu_s)
        self.memory_mb = int(memory_mb)
        self.max_output_chars = int(max_output_chars)
        self.max_api_calls = int(max_api_calls)
        self.max_recursion = int(max_recursion)
        self.max_int_bits = int(max_int_bits)
        self.max_sequence = int(max_sequence)
        self.max_message_bytes = int(max_message_bytes)
        self.max_source_chars = int(max_source_chars)

    def to_wire(self) -> dict:
        return {name: getattr(self, name) for name in self.FIELDS}

    @classmethod
    def from_wire(cls, data: dict) -> "WireLimits":
        """The limits in a RUN message; a missing or unknown field is an error (the two ends disagree)."""
        return cls(**data)
