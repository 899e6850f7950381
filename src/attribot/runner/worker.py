"""The child side of the sandbox: runs one program, then exits.

Started by the host as `python -I -S -B worker.py RFD WFD`, so it imports only the standard library (no
site-packages, no attribot, no numpy) and starts fast; the host keeps one started ahead of need. It holds
only stubs and plain data: every API call is a JSON line to the host on the WFD pipe, answered on RFD.

Inside: the program's code (checked and compiled by the host, sent marshalled), a builtins dict of
harmless functions, the bomb guards the compiler inserted calls to, and resource limits (address space,
CPU, no new file descriptors, no file writes). A stop (limit, time-out, API error) is a `SandboxStop`, a
`BaseException` that no program can catch; the first one is also recorded, so it is reported even if
something swallowed it.
"""

from __future__ import annotations

import binascii
import builtins
import fcntl
import json
import marshal
import math
import os
import resource
import signal
import sys

try:  # imported by the host as part of the package
    from attribot.runner.protocol import KIND, TAG_DICT, TAG_HANDLE, TAG_SET, TAG_TUPLE, Key, Kind, WireLimits
except ImportError:  # run as a script with -I -S (no site-packages, no script folder on the path)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from protocol import (  # type: ignore[no-redef]
        KIND,
        TAG_DICT,
        TAG_HANDLE,
        TAG_SET,
        TAG_TUPLE,
        Key,
        Kind,
        WireLimits,
    )

    del sys.path[0]

# every module the worker needs is imported above: once the channel is set up the process can open no
# file, so nothing may be imported later

__all__ = ["PROGRAM_FILENAME", "SAFE_BUILTIN_NAMES", "main"]

PROGRAM_FILENAME = "<program>"
CHANNEL_FDS = (3, 4)

SAFE_BUILTIN_NAMES = (
    "abs",
    "all",
    "any",
    "ascii",
    "bin",
    "bool",
    "callable",
    "chr",
    "dict",
    "divmod",
    "enumerate",
    "filter",
    "float",
    "frozenset",
    "hash",
    "hex",
    "int",
    "isinstance",
    "iter",
    "len",
    "list",
    "map",
    "max",
    "min",
    "next",
    "oct",
    "ord",
    "range",
    "repr",
    "reversed",
    "round",
    "set",
    "slice",
    "sorted",
    "str",
    "sum",
    "tuple",
    "zip",
    "ArithmeticError",
    "AssertionError",
    "Exception",
    "IndexError",
    "KeyError",
    "LookupError",
    "NotImplementedError",
    "RuntimeError",
    "TypeError",
    "ValueError",
    "ZeroDivisionError",
)


class ActionFailed(Exception):
    """An action or measurement that ran and failed in the world (a grasp that closed on nothing, a
    rangefinder that saw nothing in range): the one error a program may catch (`except ActionFailed as
    error:`) to go on with the next object. It holds the host's message only."""


class SandboxStop(BaseException):
    """A stop the program cannot catch: a limit, a time-out, a refused or failed API call."""

    def __init__(self, category, message):
        super().__init__(message)
        self.category = category
        self.message = message


class _State:
    def __init__(self):
        self.chan = None
        self.stopped = None  # the first SandboxStop raised, reported even if swallowed
        self.critical = False  # inside pipe I/O: timers must not raise here
        self.pending = None  # a timer that fired during pipe I/O
        self.out_len = 0
        self.max_out = 0
        self.max_bits = 0
        self.max_seq = 0
        self.max_msg = 0
        self.timed_out = False  # timers raise once at most, so the clean-up cannot be hit twice
        self.stubs = {}
        self.classes = {}
        self.stub_types = {}
        self.constructors = {}  # class name -> (the session's object that builds it, the host method)
        self.owners = {}  # class name -> {method: takes one object}: its methods that are bare functions too
        self.made = {}  # class name -> [(object, line)] the program's `ClassName(...)` made
        self.implicit = {}  # class name -> the object its bare functions act on when the program made none
        self.borrowers = set()  # the classes whose objects take bare functions as methods too
        self.looked_at = None  # the last object of those the program called a method of: what it looks at
        self.math = None
        self.typing = None
        self.future = None


STATE = _State()


def stop(category, message):
    err = SandboxStop(category, message)
    if STATE.stopped is None:
        STATE.stopped = err
    raise err


# ---- the pipe --------------------------------------------------------------------------------------


class Channel:
    def __init__(self, rfd, wfd):
        self.rfile = open(rfd, "rb", buffering=1 << 16)  # noqa: SIM115 (lives as long as the process)
        self.wfd = wfd

    def send(self, msg):
        self.send_raw(dumps(msg))

    def send_raw(self, data):
        view = memoryview(data)
        while view:
            n = os.write(self.wfd, view)
            view = view[n:]

    def recv(self):
        line = self.rfile.readline()
        if not line:
            os._exit(0)  # the host is gone
        return json.loads(line)


def dumps(msg):
    return (json.dumps(msg, separators=(",", ":")) + "\n").encode("ascii")


def exchange(data, reply=True):
    """Send a message (and wait for the answer) with timers held off, so no time-out lands mid-write."""
    STATE.critical = True
    try:
        STATE.chan.send_raw(data)
        answer = STATE.chan.recv() if reply else None
    finally:
        STATE.critical = False
    if STATE.pending is not None:
        category, message = STATE.pending
        STATE.pending = None
        stop(category, message)
    return answer


def on_timer(category, message):
    def handler(signum, frame):
        if STATE.timed_out:
            return
        STATE.timed_out = True
        if STATE.critical:
            STATE.pending = (category, message)
            return
        stop(category, message)

    return handler


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


# ---- guards the compiler inserted calls to ---------------------------------------------------------

_INTS = (int, bool)
_SEQS = (str, list, tuple, bytes)


def _check_bits(bits, what):
    if bits > STATE.max_bits:
        stop("limit", f"{what} would make an integer of about {int(bits)} bits (at most {STATE.max_bits})")


def _check_items(n, what):
    if n > STATE.max_seq:
        stop("limit", f"{what} would make a sequence of {n} items (at most {STATE.max_seq})")


def _pow_check(a, b):
    if type(a) in _INTS and type(b) in _INTS and b > 0 and abs(a) > 1:
        _check_bits(math.log2(abs(a)) * b, "**")


def _mul_check(a, b):
    ta, tb = type(a), type(b)
    if ta in _INTS:
        if tb in _INTS:
            _check_bits(a.bit_length() + b.bit_length(), "*")
        elif tb in _SEQS:
            _check_items(len(b) * a, "*")
    elif ta in _SEQS and tb in _INTS:
        _check_items(len(a) * b, "*")


def _add_check(a, b):
    if type(a) in _SEQS and type(b) in _SEQS:
        _check_items(len(a) + len(b), "+")


def _lshift_check(a, b):
    if type(a) in _INTS and type(b) in _INTS and a and b > 0:
        _check_bits(a.bit_length() + b, "<<")


def g_pow(a, b):
    _pow_check(a, b)
    return a**b


def g_mul(a, b):
    _mul_check(a, b)
    return a * b


def g_add(a, b):
    _add_check(a, b)
    return a + b


def g_iadd(a, b):
    _add_check(a, b)
    a += b
    return a


def g_lshift(a, b):
    _lshift_check(a, b)
    return a << b


def g_ipow(a, b):
    _pow_check(a, b)
    a **= b
    return a


def g_imul(a, b):
    _mul_check(a, b)
    a *= b
    return a


def g_ilshift(a, b):
    _lshift_check(a, b)
    a <<= b
    return a


def safe_pow(base, exp, mod=None):
    if mod is None:
        return g_pow(base, exp)
    if type(base) in _INTS and type(exp) in _INTS and type(mod) in _INTS:
        # the result is below the modulus, but the work grows with the exponent's and the modulus's bits
        _check_bits(max(abs(base).bit_length(), abs(mod).bit_length()), "pow(base, exp, mod)")
        work = abs(exp).bit_length() * max(abs(mod).bit_length(), 64)
        if work > STATE.max_bits * 1000:
            stop(
                "limit",
                f"pow(base, exp, mod) with an exponent of {abs(exp).bit_length()} bits and a modulus of "
                f"{abs(mod).bit_length()} bits is too much work (the product of their bits may be at most "
                f"{STATE.max_bits * 1000})",
            )
    return pow(base, exp, mod)


def safe_round(number, ndigits=None):
    # round(7, -10**7) computes 10 ** (10**7) to round with
    if type(number) in _INTS and type(ndigits) in _INTS and ndigits < 0:
        _check_bits(-ndigits * 3.33, "round")
    if ndigits is None:
        return round(number)
    return round(number, ndigits)


def safe_print(*args, sep=" ", end="\n", file=None, flush=False):
    if file is not None:
        raise TypeError("print() writes to the program's output only: drop file=")
    if sep is None:
        sep = " "
    if end is None:
        end = "\n"
    if type(sep) is not str or type(end) is not str:
        raise TypeError("print(): sep and end must be strings")
    text = sep.join(str(a) for a in args) + end
    if not text:
        return
    room = STATE.max_out - STATE.out_len
    if len(text) > room:
        if room > 0:
            STATE.out_len += room
            exchange(dumps({KIND: Kind.OUT, Key.TEXT: text[:room]}), reply=False)
        stop("limit", f"output limit reached: programs may print at most {STATE.max_out} characters")
    STATE.out_len += len(text)
    exchange(dumps({KIND: Kind.OUT, Key.TEXT: text}), reply=False)


def _log2_factorial(n):
    return math.lgamma(n + 1) / math.log(2) if n > 1 else 0.0


def make_math():
    """A fresh `math` module for the program, with the big-integer functions size-checked."""
    mod = type(math)("math")
    for name in dir(math):
        if not name.startswith("_"):
            setattr(mod, name, getattr(math, name))

    def factorial(n):
        if type(n) in _INTS and n > 1:
            _check_bits(_log2_factorial(n), "math.factorial")
        return math.factorial(n)

    def comb(n, k):
        if type(n) in _INTS and type(k) in _INTS and 0 <= k <= n:
            _check_bits(_log2_factorial(n) - _log2_factorial(k) - _log2_factorial(n - k), "math.comb")
        return math.comb(n, k)

    def perm(n, k=None):
        if type(n) in _INTS and type(k) in _INTS and 0 <= k <= n:
            _check_bits(_log2_factorial(n) - _log2_factorial(n - k), "math.perm")
        return math.perm(n, k)

    def prod(iterable, *, start=1):
        items = list(iterable)
        bits = sum(abs(v).bit_length() for v in items if type(v) in _INTS)
        _check_bits(bits, "math.prod")
        return math.prod(items, start=start)

    def gcd(*integers):
        # the result is small, but the operands must have been allowed to exist
        _check_bits(max((abs(v).bit_length() for v in integers if type(v) in _INTS), default=0), "math.gcd")
        return math.gcd(*integers)

    def lcm(*integers):
        _check_bits(sum(abs(v).bit_length() for v in integers if type(v) in _INTS), "math.lcm")
        return math.lcm(*integers)

    for f in (factorial, comb, perm, prod, gcd, lcm):
        setattr(mod, f.__name__, f)
    return mod


class TypeHint:
    """What a `typing` name is in a program: annotations are never evaluated, so it only needs to survive
    being subscripted (`List[ImagePatch]`) where an annotation is written as a value."""

    __slots__ = ("name",)

    def __init__(self, name):
        self.name = name

    def __getitem__(self, item):
        return self

    def __or__(self, other):
        return self

    __ror__ = __or__

    def __call__(self, *args, **kwargs):
        raise TypeError(f"typing.{self.name} is for annotations only in programs")

    def __repr__(self):
        return f"typing.{self.name}"


def make_typing():
    """A stand-in for `typing` (and `__future__`): every public name an inert `TypeHint`, `cast` the
    identity, TYPE_CHECKING False. The real module is never reachable from a program."""
    mod = type(math)("typing")

    def hint(name):
        if name.startswith("_"):
            raise AttributeError(name)
        return TypeHint(name)

    mod.__getattr__ = hint
    mod.TYPE_CHECKING = False
    mod.cast = lambda kind, value: value
    future = type(math)("__future__")
    future.annotations = None
    return mod, future


def safe_import(name, globals=None, locals=None, fromlist=(), level=0):  # noqa: A002 (import protocol)
    if level or name not in ("math", "typing", "__future__"):
        stop("policy", f"import {name}: only `import math` is allowed (and typing, for annotations)")
    return {"math": STATE.math, "typing": STATE.typing, "__future__": STATE.future}[name]


def build_globals():
    safe = {name: getattr(builtins, name) for name in SAFE_BUILTIN_NAMES}
    safe["print"] = safe_print
    safe["pow"] = safe_pow
    safe["round"] = safe_round
    safe["__import__"] = safe_import
    STATE.math = make_math()
    STATE.typing, STATE.future = make_typing()
    safe["ActionFailed"] = ActionFailed
    for name, cls in STATE.stub_types.items():  # isinstance(x, ImagePatch); ImagePatch(image)
        safe[name] = cls
    for owner, methods in STATE.owners.items():  # go_to_object("book"); a program's own names win
        for method in methods:
            safe.setdefault(method, make_function(owner, method))
    return {
        "__builtins__": safe,
        "__name__": "program",
        "_sb_pow": g_pow,
        "_sb_mul": g_mul,
        "_sb_lshift": g_lshift,
        "_sb_ipow": g_ipow,
        "_sb_imul": g_imul,
        "_sb_ilshift": g_ilshift,
        "_sb_add": g_add,
        "_sb_iadd": g_iadd,
        "_sb_slice": slice,
    }


# ---- one run ---------------------------------------------------------------------------------------


def error_line(exc):
    line = None
    tb = exc.__traceback__
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == PROGRAM_FILENAME:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def describe(exc, limits):
    if isinstance(exc, SandboxStop):
        return exc.category, exc.message
    if type(exc) is ActionFailed:  # not caught: the API's error, as a stop would have reported it
        return "api", str(exc)
    if isinstance(exc, MemoryError):
        return "limit", f"memory limit reached: the program may use about {limits.memory_mb} MB"
    if isinstance(exc, RecursionError):
        return "limit", f"recursion too deep: at most {limits.max_recursion} nested calls"
    if isinstance(exc, OSError):  # e.g. a codec that would load a module from disk
        return "runtime", f"{type(exc).__name__}: programs cannot open files or load modules"
    try:
        text = str(exc)
    except BaseException:  # noqa: BLE001 (a message that cannot be made is no reason to fail)
        text = ""
    text = text if len(text) <= 500 else text[:497] + "..."
    return "runtime", f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def apply_limits(limits):
    signal.signal(signal.SIGALRM, on_timer("timeout", f"the program ran longer than {limits.wall_s} s"))
    signal.signal(
        signal.SIGPROF, on_timer("timeout", f"the program used more than {limits.cpu_s} s of CPU time")
    )
    mem = limits.memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
    used = resource.getrusage(resource.RUSAGE_SELF)
    cpu = int(used.ru_utime + used.ru_stime + limits.cpu_s) + 2
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))  # backstop: the kernel kills past it
    signal.setitimer(signal.ITIMER_PROF, limits.cpu_s)
    signal.setitimer(signal.ITIMER_REAL, limits.wall_s)


def stop_timers():
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.setitimer(signal.ITIMER_PROF, 0)


def run(request):
    """Run the program; return the final message for the host (raises only if a timer lands late)."""
    limits = WireLimits.from_wire(request[Key.LIMITS])
    STATE.max_out = limits.max_output_chars
    STATE.max_bits = limits.max_int_bits
    STATE.max_seq = limits.max_sequence
    STATE.max_msg = limits.max_message_bytes
    STATE.classes = {name: tuple(methods) for name, methods in request[Key.CLASSES].items()}
    functions = request.get(Key.FUNCTIONS) or {}
    STATE.owners = {owner: dict(spec[Key.FN_METHODS]) for owner, spec in functions.items()}
    borrowed = {}
    for owner, spec in functions.items():
        for on, methods in spec[Key.FN_ON].items():
            borrowed.setdefault(on, []).extend((owner, m, spec[Key.FN_METHODS][m]) for m in methods)
    STATE.stub_types = {
        name: stub_class(name, methods, borrowed.get(name, ())) for name, methods in STATE.classes.items()
    }
    STATE.borrowers = set(borrowed)
    code = marshal.loads(binascii.a2b_base64(request[Key.CODE]))
    g = build_globals()
    args = [decode(a) for a in request[Key.ARGS]]
    for cls_name, (wire, method) in (request.get(Key.CONSTRUCTORS) or {}).items():
        STATE.constructors[cls_name] = (decode(wire), method)
    entry = request[Key.ENTRY]
    sys.setrecursionlimit(len_stack() + limits.max_recursion + 10)
    apply_limits(limits)
    try:
        exec(code, g)  # noqa: S102 (the code was checked and compiled by the host)
        fn = g.get(entry)
        if not callable(fn):
            raise TypeError(f"{entry} is not a function")
        value = call_entry(fn, args, entry)
        if STATE.stopped is not None:
            raise STATE.stopped
        try:
            msg = dumps({KIND: Kind.DONE, Key.VALUE: encode(value)})
        except Unsupported as e:
            msg = error_message(
                "runtime",
                f"{entry} returned a {e}; return an API object, a number, a "
                "string, a bool or a list of those",
                None,
            )
        except (ValueError, RecursionError) as e:
            msg = error_message(
                "limit",
                f"{entry} returned a value that cannot be passed back ({type(e).__name__}: {str(e)[:200]})",
                None,
            )
    except BaseException as exc:  # noqa: BLE001 (every failure becomes a structured error)
        category, message = describe(exc, limits)
        msg = error_message(category, message, error_line(exc))
        del exc
    STATE.critical = True
    stop_timers()
    g.clear()
    return msg


def error_message(category, message, line):
    first = STATE.stopped
    if first is not None and category != first.category:
        category, message = first.category, first.message  # a stop that something swallowed
    return dumps({KIND: Kind.FAILED, Key.CATEGORY: category, Key.MESSAGE: message, Key.LINE: line})


def len_stack():
    depth, frame = 0, sys._getframe()
    while frame is not None:
        depth += 1
        frame = frame.f_back
    return depth


def setup_channel(rfd, wfd):
    """Move the pipe ends to fds 3 and 4, close everything else, and allow no new descriptors."""
    hi_r = fcntl.fcntl(rfd, fcntl.F_DUPFD, 64)
    hi_w = fcntl.fcntl(wfd, fcntl.F_DUPFD, 64)
    os.close(rfd)
    os.close(wfd)
    os.dup2(hi_r, CHANNEL_FDS[0])
    os.dup2(hi_w, CHANNEL_FDS[1])
    os.closerange(CHANNEL_FDS[1] + 1, 4096)
    resource.setrlimit(resource.RLIMIT_NOFILE, (CHANNEL_FDS[1] + 1, CHANNEL_FDS[1] + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return Channel(CHANNEL_FDS[0], CHANNEL_FDS[1])


def main(argv):
    STATE.chan = setup_channel(int(argv[1]), int(argv[2]))
    STATE.chan.send({KIND: Kind.READY})
    request = STATE.chan.recv()
    if request.get(KIND) != Kind.RUN:
        os._exit(2)
    STATE.chan.send({KIND: Kind.GO})
    limits = WireLimits.from_wire(request[Key.LIMITS])
    try:
        try:
            msg = run(request)
        except BaseException as exc:  # noqa: BLE001 (a timer that fired during the clean-up)
            STATE.critical = True
            stop_timers()
            category, message = describe(STATE.stopped or exc, limits)
            msg = error_message(category, message, error_line(exc))
        STATE.chan.send_raw(msg)
    finally:
        os._exit(0)  # no clean-up code of any kind runs after the program


if __name__ == "__main__":
    main(sys.argv)
