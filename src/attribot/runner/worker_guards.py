"""The builtins a program gets (the child side): the harmless names, the size guards the compiler inserted
calls to (`_sb_pow`, `_sb_mul`, ...), and size-checked `pow`, `round`, `math` and a stand-in `typing`.

A guard stops the program (`worker_pipe.stop`, category `limit`) before an operation would build an integer
or a sequence past the run's limits. Run inside the sandbox (`worker.py`), so standard library only.
"""

from __future__ import annotations

import math

try:  # imported by the host as part of the package
    from attribot.runner.worker_pipe import STATE, stop
except ImportError:  # in the worker, run as a script: its folder is on the path while it imports
    from worker_pipe import STATE, stop  # type: ignore[no-redef]

__all__ = ["SAFE_BUILTIN_NAMES", "make_math", "make_typing", "safe_import", "safe_pow", "safe_round"]

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
