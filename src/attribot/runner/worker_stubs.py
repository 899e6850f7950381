"""How the program sees the host's objects (the child side): values across the pipe, the stub classes whose
methods are API calls, and the conveniences of the paper authors' dialect.

Run inside the sandbox (`worker.py`), so standard library only; every call is still one of the host's API
methods, sent through `worker_pipe.exchange`.
"""

from __future__ import annotations

import sys

try:  # imported by the host as part of the package
    from attribot.runner.protocol import (
        KIND,
        PROGRAM_FILENAME,
        TAG_DICT,
        TAG_HANDLE,
        TAG_SET,
        TAG_TUPLE,
        Key,
        Kind,
    )
    from attribot.runner.worker_pipe import STATE, ActionFailed, dumps, exchange, stop
except ImportError:  # in the worker, run as a script: its folder is on the path while it imports
    from protocol import KIND, PROGRAM_FILENAME, TAG_DICT, TAG_HANDLE, TAG_SET, TAG_TUPLE, Key, Kind  # type: ignore[no-redef]
    from worker_pipe import STATE, ActionFailed, dumps, exchange, stop  # type: ignore[no-redef]

__all__ = ["Stub", "Unsupported", "call_entry", "decode", "encode", "make_function", "stub_class"]


# ---- values across the pipe ------------------------------------------------------------------------


class Unsupported(Exception):
    pass


def encode(value):
    """Plain data and stubs to JSON; anything else is refused (a function, a generator, a module)."""
    t = type(value)
    if value is None or t is bool or t is int or t is float or t is str:
        return value
    if t is Reading:
        return float(value)
    if t is Text:
        return str(value)
    if t is list or t is Found:
        return [encode(v) for v in value]
    if t is tuple:
        return {TAG_TUPLE: [encode(v) for v in value]}
    if t is dict:
        return {TAG_DICT: [[encode(k), encode(v)] for k, v in value.items()]}
    if t is set or t is frozenset:
        return {TAG_SET: [encode(v) for v in value]}
    if isinstance(value, Stub):
        return {TAG_HANDLE: object.__getattribute__(value, "_sb_handle")}
    raise Unsupported(t.__name__)


def decode(data):
    t = type(data)
    if t is list:
        return [decode(v) for v in data]
    if t is dict:
        if TAG_HANDLE in data:
            return make_stub(data)
        if TAG_TUPLE in data:
            return tuple(decode(v) for v in data[TAG_TUPLE])
        if TAG_DICT in data:
            return {decode(k): decode(v) for k, v in data[TAG_DICT]}
        if TAG_SET in data:
            return {decode(v) for v in data[TAG_SET]}
        raise ValueError("bad message from host")
    return data


# ---- stubs -----------------------------------------------------------------------------------------


def program_line(frame):
    """The line of the program being executed at `frame` or below it on the stack."""
    while frame is not None:
        if frame.f_code.co_filename == PROGRAM_FILENAME:
            return frame.f_lineno
        frame = frame.f_back
    return None


class Stub:
    """A host object as the program sees it: read-only plain attributes and methods that call the host."""

    __slots__ = ("_sb_handle", "_sb_attrs")
    _sb_class = "Stub"

    def __getattr__(self, name):
        attrs = object.__getattribute__(self, "_sb_attrs")
        if name in attrs:
            value = attrs[name]
            return list(value) if type(value) is list else value
        cls = type(self)
        names = sorted(list(attrs) + list(STATE.classes.get(cls._sb_class, ())))
        raise AttributeError(f"{cls._sb_class} has no attribute {name!r}; it has: {', '.join(names)}")

    def __setattr__(self, name, value):
        raise AttributeError(f"{type(self)._sb_class} objects are read-only")

    def __delattr__(self, name):
        raise AttributeError(f"{type(self)._sb_class} objects are read-only")

    def __repr__(self):
        attrs = object.__getattribute__(self, "_sb_attrs")
        inner = ", ".join(f"{k}={v!r}" for k, v in attrs.items())
        return f"{type(self)._sb_class}({inner})"


def rpc(stub, method, args, kwargs, receiver=None):
    line = program_line(sys._getframe(2))
    cls = type(stub)._sb_class
    if cls in STATE.borrowers:
        STATE.looked_at = stub
    elif receiver is None and cls in STATE.owners and args and isinstance(args[0], str):
        # an object named to a robot method (`go_to_object("object")` in a loop over patches, as the paper's
        # prompt writes it): the host hears which object the program last looked at, which it may mean
        receiver = STATE.looked_at
    try:
        msg = {
            KIND: Kind.CALL,
            Key.HANDLE: object.__getattribute__(stub, "_sb_handle"),
            Key.METHOD: method,
            Key.ARGS: [encode(a) for a in args],
            Key.KWARGS: {k: encode(v) for k, v in kwargs.items()},
            Key.LINE: line,
        }
        if receiver is not None:
            msg[Key.RECEIVER] = object.__getattribute__(receiver, "_sb_handle")
    except Unsupported as e:
        stop(
            "api",
            f"{cls}.{method}: cannot pass a {e} to the API; pass numbers, strings, bools, "
            "lists, dicts or API objects",
        )
    except RecursionError:
        stop("limit", f"{cls}.{method}: an argument is nested too deeply")
    data = dumps(msg)
    if len(data) > STATE.max_msg:
        stop(
            "limit",
            f"{cls}.{method}: the arguments are too large ({len(data)} bytes, at most {STATE.max_msg})",
        )
    answer = exchange(data)
    kind = answer.get(KIND)
    if kind == Kind.RETURN:
        return shaped(decode(answer[Key.VALUE]), cls, method, args)
    if kind == Kind.ACTION_FAILED:
        raise ActionFailed(str(answer.get(Key.MESSAGE, "the action failed")))
    stop(answer.get(Key.CATEGORY, "api"), answer.get(Key.MESSAGE, "the API call failed"))


def construct(cls, *args, **kwargs):
    """`ClassName(...)` in a program: the host's constructor method on the session's object of that class
    (the paper's dialect: `ImagePatch(image)`, `Robot(sensors=[...])`)."""
    name = cls._sb_class
    found = STATE.constructors.get(name)
    if found is None:
        raise TypeError(f"{name} objects come from the API: use the `image` and `robot` execute_command gets")
    made = rpc(found[0], found[1], args, kwargs)
    if name in STATE.owners:
        STATE.made.setdefault(name, []).append((made, program_line(sys._getframe(1))))
    return made


def call_entry(fn, args, entry):
    """Call the entry point with as many of `args` as it takes: `execute_command(image)` (the paper's and
    ViperGPT's form) gets the image, `execute_command(image, robot)` both."""
    code = getattr(fn, "__code__", None)
    if code is not None and not code.co_flags & 0x04:  # no *args: pass what it names
        takes = code.co_argcount
        needs = takes - len(fn.__defaults__ or ())
        if needs > len(args):
            raise TypeError(
                f"{entry}() needs {needs} arguments, and it is called with {len(args)}: "
                f"define {entry}(image, robot) or {entry}(image)"
            )
        args = args[:takes]
    return fn(*args)


def make_method(cls_name, method):
    def call(self, *args, **kwargs):
        return rpc(self, method, args, kwargs)

    call.__name__ = method
    call.__qualname__ = f"{cls_name}.{method}"
    return call


def no_init(self, *args, **kwargs):
    pass


def stub_class(cls_name, methods, borrowed=()):
    """The program's class `cls_name`: its objects are the host's, `isinstance(x, cls_name)` works, and
    calling it is the paper dialect's constructor. `borrowed`: (owner, method, takes one object) of another
    class's methods its objects take too (`book_patch.measure_weight("book")`)."""
    namespace = {"__slots__": (), "_sb_class": cls_name, "__new__": construct, "__init__": no_init}
    for m in methods:
        namespace[m] = make_method(cls_name, m)
    for owner, m, takes in borrowed:
        if m not in namespace:
            namespace[m] = make_borrowed(owner, m, takes)
    return type(cls_name, (Stub,), namespace)


def make_stub(data):
    handle = data[TAG_HANDLE]
    stub = STATE.stubs.get(handle)
    if stub is None:
        cls = STATE.stub_types[data[Key.STUB_CLASS]]
        stub = object.__new__(cls)
        object.__setattr__(stub, "_sb_handle", handle)
        object.__setattr__(stub, "_sb_attrs", {k: decode(v) for k, v in data[Key.STUB_ATTRS].items()})
        STATE.stubs[handle] = stub
    return stub


# ---- the paper authors' habits ---------------------------------------------------------------------
# Their prompt calls robot methods as bare functions (`go_to_object("book")`) and on patches
# (`book_patch.measure_weight("book")`), reads a weight as a dictionary (`weight["book"]`), uses the list
# `find` returns as the patch (`tv_patch = image_patch.find("tv")`) and compares answers with "Yes". These
# are conveniences of the program's side only: every call is still one of the host's API methods.


class Reading(float):
    """A number a robot method returned. The paper's prompt also reads it as a dictionary from the object's
    name (`weight = book_patch.measure_weight("book")`, then `weight["book"]`): indexed by a name or a
    patch, it is its own value."""

    __slots__ = ()

    def __getitem__(self, key):
        if isinstance(key, str | Stub):
            return float(self)
        kind = type(key).__name__
        raise TypeError(
            f"a measurement is indexed by the object's name, e.g. weight['book'], not by a {kind}"
        )


def _folded(text):
    return text.strip().rstrip(".!").strip().casefold()


class Text(str):
    """A text an API method answered: compared with `==` it ignores case, the spaces around it and a final
    full stop, so that `visual_query(...) == "Yes"` (the paper's prompt) and `== "yes"` (ViperGPT's) both
    read a model's "yes". Hashed as written, like the str it is."""

    __slots__ = ()

    def __eq__(self, other):
        if isinstance(other, str):
            return _folded(self) == _folded(other)
        return NotImplemented

    def __ne__(self, other):
        same = self.__eq__(other)
        return same if same is NotImplemented else not same

    __hash__ = str.__hash__


class Found(list):
    """A list of API objects a call returned (`image_patch.find("tv")`). The paper's prompt uses it as the
    object itself (`tv_patch.measure_distance("tv")`): holding exactly one, the list answers for it; holding
    none or several, it says so and how to write it."""

    __slots__ = ("_sb_what",)

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        if len(self) == 1:
            return getattr(self[0], name)
        what = self._sb_what
        if not self:
            raise AttributeError(
                f"{what} found nothing, and .{name} was asked of that empty list: check that the list is not "
                "empty (if patches: ...) before using it"
            )
        raise AttributeError(
            f"{what} found {len(self)} objects, and .{name} was asked of the list, which cannot tell which "
            "one is meant: take one (patches[0], or max(patches, key=...)) or loop over them "
            "(for patch in patches:)"
        )


def shaped(value, cls, method, args):
    """A value an API call returned, as the program gets it: a number from a method of a class whose methods
    are bare functions too (the robot's) a `Reading`, a text a `Text`, a list of API objects a `Found`."""
    t = type(value)
    if t is float and cls in STATE.owners:
        return Reading(value)
    if t is str:
        return Text(value)
    if t is list and all(isinstance(v, Stub) for v in value):
        found = Found(value)
        first = args[0] if args else None
        found._sb_what = f"{method}({str(first)!r})" if isinstance(first, str) else f"{method}()"
        return found
    return value


def bound(owner, name):
    """The object of class `owner` a bare function (or a borrowed method) acts on: the one the program made
    (several made alike count as one), else one made for it with no arguments (the session's own, as
    `ClassName()` gives it). Objects made with different attributes are ambiguous: a stop that names them."""
    made = STATE.made.get(owner, ())
    kinds = {}
    for obj, line in made:
        attrs = object.__getattribute__(obj, "_sb_attrs")
        key = repr(sorted(attrs.items()))
        if key not in kinds:
            kinds[key] = (obj, line, attrs)
    if len(kinds) > 1:
        each = "; ".join(
            f"line {line}: {owner}({', '.join(f'{k}={v!r}' for k, v in attrs.items())})"
            for _, line, attrs in kinds.values()
        )
        stop(
            "api",
            f"{name}() cannot tell which {owner} acts: the program made {len(kinds)} different ones "
            f"({each}); make one {owner}(...) with everything the program uses, or call the method on the "
            f"one you mean ({owner.lower()}.{name}(...))",
        )
    if made:
        return made[-1][0]
    obj = STATE.implicit.get(owner)
    if obj is None:
        found = STATE.constructors.get(owner)
        if found is None:
            stop("api", f"{name}() needs a {owner}, and this program runs without one")
        obj = STATE.implicit[owner] = rpc(found[0], found[1], (), {})
    return obj


def make_function(owner, method):
    """The bare function `method(...)` of the program: `owner`'s method on the object `bound` gives."""

    def call(*args, **kwargs):
        return rpc(bound(owner, method), method, args, kwargs)

    call.__name__ = call.__qualname__ = method
    return call


def make_borrowed(owner, method, takes):
    """`owner`'s method taken by another class's objects: `patch.method(...)` acts on the object `bound`
    gives, with the patch itself as the argument when the call names none and the method takes one; the
    host hears which patch it was called on (a name in the call may mean it: `book_patch.pick_up("book")`)."""

    def call(self, *args, **kwargs):
        if takes and not args and not kwargs:
            args = (self,)
        return rpc(bound(owner, method), method, args, kwargs, receiver=self)

    call.__name__ = method
    return call
