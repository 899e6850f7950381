"""Escape and exhaustion attempts against the runner, as one table with the expected category as a
column. Every attempt is refused (statically) or stopped (while running) with that category, and the
same runner then runs a normal program correctly: no attempt breaks the host or leaks into the next run.
"""

from __future__ import annotations

import re
import textwrap
from typing import ClassVar

import pytest

from attribot.runner import Limits, ProgramRunner


class Img:
    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("width", "label")
    API_METHODS: ClassVar[tuple[str, ...]] = ("find", "exists")

    def __init__(self, width: float = 640.0, label: str = "scene") -> None:
        self.width, self.label = width, label
        self.calls = 0

    def find(self, name: str) -> list[Img]:
        self.calls += 1
        return [Img(10.0 + i, f"{name}{i}") for i in range(2)]

    def exists(self, name: str) -> bool:
        self.calls += 1
        return True


LIMITS = Limits(
    wall_s=0.6,
    cpu_s=0.5,
    memory_mb=256,
    max_output_chars=2_000,
    max_api_calls=200,
    max_recursion=100,
    max_message_bytes=100_000,
)

NORMAL = """
import math
def execute_command(image):
    cups = image.find("cup")
    print("found", len(cups))
    return [c.label for c in cups], math.floor(image.width / 3)
"""


def program(body: str) -> str:
    return "def execute_command(image):\n" + textwrap.indent(textwrap.dedent(body).strip("\n"), "    ") + "\n"


# (name, program, expected category)
ATTEMPTS: list[tuple[str, str, str]] = [
    # ---- imports in every spelling
    ("import os", program("import os\nreturn os.listdir('/')"), "policy"),
    ("import os.path", program("import os.path"), "policy"),
    ("from os import system", program("from os import system"), "policy"),
    ("import math, sys", program("import math, sys"), "policy"),
    ("relative import", "from . import worker\n" + program("return 1"), "policy"),
    ("from math import *", "from math import *\n" + program("return 1"), "policy"),
    ("__import__ call", program("return __import__('os')"), "policy"),
    ("import pickle", program("import pickle\nreturn pickle.loads(b'')"), "policy"),
    ("import importlib", program("import importlib"), "policy"),
    ("math dunder loader", "import math\n" + program("return math.__loader__"), "policy"),
    # ---- dunder walks and introspection
    ("subclasses walk", program("return ().__class__.__bases__[0].__subclasses__()"), "policy"),
    ("stub class", program("return image.__class__"), "policy"),
    ("stub dict", program("return image.__dict__"), "policy"),
    ("stub internals", program("return image._sb_handle"), "policy"),
    ("bound method globals", program("return image.find.__func__.__globals__"), "policy"),
    ("builtin self is a module", program("return print.__self__"), "policy"),
    ("function code", program("return execute_command.co_code"), "policy"),
    ("type mro", program("return str.mro()[-1]"), "policy"),
    ("getattr with a built string", program("n = '_' + '_class__'\nreturn getattr(image, n)"), "policy"),
    ("getattr by alias", program("g = [getattr][0]\nreturn g"), "policy"),
    ("vars", program("return vars(image)"), "policy"),
    ("type()", program("return type(image)"), "policy"),
    ("dir", program("return dir(image)"), "policy"),
    ("globals", program("return globals()"), "policy"),
    ("builtins by name", program("return __builtins__"), "policy"),
    ("eval", program("return eval('1+1')"), "policy"),
    ("exec", program("exec('x = 1')"), "policy"),
    ("compile", program("return compile('1', 'f', 'eval')"), "policy"),
    ("open a file", program("return open('/etc/passwd').read()"), "policy"),
    ("breakpoint", program("breakpoint()"), "policy"),
    ("object and super", program("return object"), "policy"),
    # ---- generator, coroutine, frame and exception introspection
    ("generator frame walk", program("g = (x for x in [1])\nreturn g.gi_frame.f_back.f_globals"), "policy"),
    ("generator code", program("g = (x for x in [1])\nreturn g.gi_code"), "policy"),
    ("coroutine", "async def f():\n    return 1\n" + program("return f().cr_frame"), "policy"),
    ("yield generator", program("def gen():\n    yield 1\nreturn list(gen())"), "policy"),
    ("lambda yield", program("f = lambda: (yield)\nreturn f"), "policy"),
    (
        "exception traceback",
        program("try:\n    1 / 0\nexcept Exception as e:\n    return e.__traceback__"),
        "policy",
    ),
    ("except star", program("try:\n    pass\nexcept* ValueError:\n    pass"), "policy"),
    # ---- the one catchable error (issue 18): nothing of it but its message, and no stop caught with it
    (
        "ActionFailed traceback",
        program("try:\n    image.find('x')\nexcept ActionFailed as e:\n    return e.__traceback__"),
        "policy",
    ),
    ("ActionFailed with_traceback", program("return ActionFailed('x').with_traceback(None)"), "policy"),
    (
        "except ActionFailed around a bomb",
        program("try:\n    x = 10 ** 10 ** 8\nexcept ActionFailed:\n    return 1"),
        "limit",
    ),
    (
        "except ActionFailed around a loop",
        program("try:\n    while True:\n        pass\nexcept ActionFailed:\n    return 1"),
        "timeout",
    ),
    ("finally ends a stop", program("try:\n    x = 10 ** 10 ** 8\nfinally:\n    return 1"), "policy"),
    (
        "except a tuple with Exception",
        program("try:\n    pass\nexcept (ActionFailed, Exception):\n    pass"),
        "policy",
    ),
    (
        "except ActionFailed's base",
        program("try:\n    pass\nexcept ActionFailed.mro()[1]:\n    pass"),
        "policy",
    ),
    (
        "rebound ActionFailed",
        "ActionFailed = Exception\n" + program("try:\n    1 / 0\nexcept ActionFailed:\n    return 1"),
        "policy",
    ),
    (
        "ActionFailed as a parameter",
        "def f(ActionFailed):\n"
        + program("return 1")
        .replace("def execute_command(image):\n", "")
        .replace("    return", "    try:\n        1 / 0\n    except ActionFailed:\n        return")
        + program("return f(Exception)"),
        "policy",
    ),
    (
        "ActionFailed bound by except",
        program("try:\n    image.find('x')\nexcept ActionFailed as ActionFailed:\n    return 1"),
        "policy",
    ),
    # ---- typing, API classes and the main block (issue 18)
    (
        "typing is a stand-in",
        "import typing\n" + program("return typing.get_type_hints(execute_command)"),
        "runtime",
    ),
    ("typing dunder", "import typing\n" + program("return typing.__dict__"), "policy"),
    ("typing private", "from typing import _GenericAlias\n" + program("return 1"), "policy"),
    ("future feature", "from __future__ import barry_as_FLUFL\n" + program("return 1"), "policy"),
    ("API class internals", program("return Img.__subclasses__()"), "policy"),
    ("API method globals", program("return Img.find.__globals__"), "policy"),
    ("API class without a constructor", program("return Img()"), "runtime"),
    ("API method on a foreign object", program("return Img.find(3, 'cup')"), "runtime"),
    (
        "code in a main block runs nowhere",
        program("return 1") + "if __name__ == '__main__':\n    import os\n" + "__name__ = 1\n",
        "policy",
    ),
    ("with_traceback", program("return ValueError('x').with_traceback(None)"), "policy"),
    ("traceback frame attr", program("return image.tb_frame"), "policy"),
    # ---- format-string traversal
    ("str.format traversal", program("return '{0.__class__}'.format(image)"), "policy"),
    ("str.format method reference", program("f = str.format\nreturn f('{0.find}', image)"), "policy"),
    ("format_map", program("return '{x}'.format_map({'x': image})"), "policy"),
    ("format builtin", program("return format(image, '')"), "policy"),
    ("f-string dunder", program("return f'{image.__class__}'"), "policy"),
    # ---- forbidden statements
    ("class", "class A:\n    pass\n" + program("return A"), "policy"),
    ("global", program("global image\nreturn 1"), "policy"),
    ("nonlocal", program("def f():\n    nonlocal image\nreturn 1"), "policy"),
    ("with", program("with image:\n    pass"), "policy"),
    ("match", program("match image:\n    case _:\n        return 1"), "policy"),
    ("decorator", "@print\ndef f():\n    pass\n" + program("return 1"), "policy"),
    # ---- overriding or deleting API and sandbox names
    ("assign a method", program("image.find = lambda name: []\nreturn image.find('x')"), "policy"),
    ("delete a method", program("del image.find"), "policy"),
    ("rebind a guard", "_sb_pow = None\n" + program("return 2 ** 3"), "policy"),
    (
        "shadowed builtins keep the guards",
        "pow = None\nint = None\n" + program("return 10 ** 10 ** 8"),
        "limit",
    ),
    ("deleted print", "del print\n" + program("return 1"), "runtime"),
    (
        "catching the sandbox's stop",
        program("try:\n    x = 10 ** 10 ** 8\nexcept BaseException:\n    return 1"),
        "policy",
    ),
    ("swallowing via key function", program("return sorted([1, 2], key=lambda v: 10 ** 10 ** 8)"), "limit"),
    # ---- one-operation bombs
    ("power bomb", program("return 10 ** 10 ** 8"), "limit"),
    ("pow() bomb", program("return pow(10, 10 ** 8)"), "limit"),
    ("string repeat bomb", program("return 'a' * 10 ** 10"), "limit"),
    ("list repeat bomb", program("return [0] * 10 ** 10"), "limit"),
    ("reversed repeat bomb", program("return 10 ** 10 * [0]"), "limit"),
    ("shift bomb", program("return 1 << 10 ** 10"), "limit"),
    ("augmented repeat bomb", program("s = 'a'\ns *= 10 ** 10\nreturn s"), "limit"),
    ("augmented power on an item", program("a = [10]\na[0] **= 10 ** 8\nreturn a"), "limit"),
    ("squaring loop", program("x = 3\nwhile True:\n    x = x * x"), "limit"),
    ("factorial bomb", "import math\n" + program("return math.factorial(10 ** 8)"), "limit"),
    ("lcm bomb", "import math\n" + program("return math.lcm(*range(1, 100000))"), "limit"),
    ("lcm of two large", "import math\n" + program("x = 10 ** 30000\nreturn math.lcm(x, x - 1)"), "limit"),
    (
        "gcd of operands grown past the guard",
        "import math\n"
        + program("x = 10 ** 30000\nfor i in range(1200):\n    x = x + x\nreturn math.gcd(x, x - 1)"),
        "limit",
    ),
    ("modular pow bomb", program("return pow(3, 10 ** 30000, 10 ** 30000 + 1)"), "limit"),
    ("int.from_bytes past the guard", program("return int.from_bytes(b'\\xff' * 1000000, 'big')"), "policy"),
    ("round to a huge negative place", program("return round(7, -10 ** 7)"), "limit"),
    ("ljust memory bomb", program("return 'a'.ljust(10 ** 10)"), "limit"),
    ("range to list memory bomb", program("return list(range(10 ** 9))"), "limit"),
    ("doubling memory", program("s = 'a'\nwhile True:\n    s = s + s"), "limit"),
    ("doubling a list in place", program("x = [0]\nwhile True:\n    x += x"), "limit"),
    # ---- time
    ("endless loop", program("while True:\n    pass"), "timeout"),
    ("long C call", program("return sum(range(10 ** 13))"), "timeout"),
    ("top-level loop", "while True:\n    x = 1\n" + program("return 1"), "timeout"),
    ("busy counting", program("x = 0\nfor i in range(10 ** 10):\n    x += i"), "timeout"),
    # ---- recursion
    ("deep recursion", "def f(n):\n    return f(n + 1)\n" + program("return f(0)"), "limit"),
    ("lambda recursion", program("f = lambda n: f(n + 1)\nreturn f(0)"), "limit"),
    ("nested value returned", program("a = []\nfor i in range(100000):\n    a = [a]\nreturn a"), "limit"),
    ("nested value printed", program("a = []\nfor i in range(100000):\n    a = [a]\nprint(a)"), "limit"),
    # ---- output floods
    ("print flood", program("while True:\n    print('x' * 100)"), "limit"),
    ("one huge print", program("print('x' * 100000)"), "limit"),
    ("print to a file", program("print('x', file=image)"), "runtime"),
    # ---- the API budget and the pipe
    ("10,000 API calls", program("for i in range(10000):\n    image.exists('cup')"), "limit"),
    ("huge API argument", program("return image.find('x' * 1000000)"), "limit"),
    ("huge return value", program("return 'x' * 5000000"), "limit"),
    ("function as API argument", program("return image.find(print)"), "api"),
    ("deeply nested expression", program("return " + "1*" * 2000 + "1"), "syntax"),
    ("fullwidth getattr", program("return ｇｅｔａｔｔｒ(image, 'x')"), "policy"),
    ("fullwidth dunder", program("return image.＿＿class＿＿"), "syntax"),
    ("int too long for text", program("return str(10 ** 5000)"), "runtime"),
    ("codec that loads a module from disk", program("return b'x'.decode('utf_7')"), "runtime"),
]


@pytest.fixture(scope="module")
def runner():
    with ProgramRunner(classes=[Img], limits=LIMITS) as r:
        yield r


def test_the_table_is_large_enough():
    assert len(ATTEMPTS) >= 40
    assert len({name for name, _, _ in ATTEMPTS}) == len(ATTEMPTS)


@pytest.mark.parametrize(("name", "source", "category"), ATTEMPTS, ids=[a[0] for a in ATTEMPTS])
def test_attempt_is_stopped_and_the_runner_serves_on(runner, name, source, category):
    image = Img()
    res = runner.run(source, args=[image])
    assert not res.ok, f"{name}: ran to the end with {res.value!r}"
    assert res.error.category == category, f"{name}: {res.error}"
    assert res.error.message
    text = res.error.model_dump_json()
    assert "Traceback" not in text and "site-packages" not in text and "/runner/" not in text
    assert not re.search(r"(?:/[\w.\-]+){2,}", res.error.message), res.error.message  # no host paths
    if category == "limit" and "API calls" in res.error.message:
        assert image.calls == LIMITS.max_api_calls
    after = runner.run(NORMAL, args=[Img(width=90.0)])
    assert after.ok, f"after {name}: {after.error}"
    assert after.value == [["cup0", "cup1"], 30] and after.output == "found 2\n"


def test_output_cap_keeps_the_output_up_to_the_cap(runner):
    res = runner.run(program("while True:\n    print('x' * 100)"), args=[Img()])
    assert res.error.category == "limit" and len(res.error.output) == LIMITS.max_output_chars


def test_bomb_errors_name_the_line(runner):
    res = runner.run(program("x = 1\ny = 'a' * 10 ** 10"), args=[Img()])
    assert res.error.line == 3 and "'a' * 10 ** 10" in res.error.snippet
