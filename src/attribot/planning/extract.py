"""Getting the program out of a model's reply.

Models answer in many shapes: one fenced block (```python, ```py, or a bare ```), several blocks (a draft
and a fix, or usage examples), code with prose around it and no fence, or no code at all. The program is
the block that defines the entry point; when none does, the reply is refused with a message that can go
back to the model as feedback.
"""

from __future__ import annotations

import ast
import re

from attribot.api.prompt import API_CLASS_NAMES
from attribot.planning.base import ENTRY_POINT, NoProgram

__all__ = ["extract_program", "first_line"]

# An opening fence with an optional language tag, the body, and a closing fence or the end of the reply
# (a reply cut off by a token limit still carries most of its program).
_FENCE = re.compile(r"^[ \t]*(`{3,}|~{3,})[ \t]*([\w+.-]*)[^\n]*\n(.*?)(?:^[ \t]*\1[ \t]*$|\Z)", re.M | re.S)
_PYTHON_TAGS = {"", "python", "py", "python3", "py3", "ipython", "pycon"}
_DEF = re.compile(rf"^[ \t]*def[ \t]+{ENTRY_POINT}[ \t]*\(", re.M)


def first_line(reply: str, limit: int = 120) -> str:
    """The first non-blank line of `reply`, shortened: what an error shows of a reply."""
    for line in reply.splitlines():
        if line.strip():
            line = line.strip()
            return line if len(line) <= limit else line[:limit] + "..."
    return ""


def extract_program(reply: str, entry: str = f"{ENTRY_POINT}(image, robot)") -> str:
    """The program in `reply`: the fenced (or bare) code that defines the entry point. `entry` is the
    entry point as the prompt shown taught it (`execute_command(image, robot)`, or `execute_command(image)`
    for the paper's prompt): what a refusal asks for.

    Several fenced blocks: the last one that defines the entry point and parses wins (models put the
    corrected version last); other languages' blocks are only used when no python block qualifies.
    Top-level lines that would break the run, such as a `if __name__ == "__main__":` block or a call of
    the entry point, are dropped, and so are the API's classes where the reply copies them from the prompt
    around its function (the runner provides them). Raises `NoProgram` with a message meant for the model
    otherwise.

    >>> extract_program("Sure:\\n```python\\ndef execute_command(image, robot):\\n    return 1\\n```")
    'def execute_command(image, robot):\\n    return 1\\n'
    """
    fix = _fix(entry)
    if not isinstance(reply, str) or not reply.strip():
        raise NoProgram(
            "no code in the reply: the reply is empty", fix, reply=reply if isinstance(reply, str) else None
        )
    blocks = [(m.group(2).lower(), m.group(3)) for m in _FENCE.finditer(reply)]
    defining = [(tag in _PYTHON_TAGS, body) for tag, body in blocks if _DEF.search(body)]
    if not blocks:
        bare = _bare_code(reply)
        if bare is not None:
            defining = [(True, bare)]
    if not defining:
        if blocks or _looks_like_code(reply):
            raise NoProgram(
                f"the code in the reply does not define {entry} (the reply starts: {first_line(reply)!r})",
                fix,
                reply=reply,
            )
        raise NoProgram(f"no code in the reply (the reply starts: {first_line(reply)!r})", fix, reply=reply)
    # Preference, each time the last such block: python and parses > parses > python > any. A block that
    # does not parse is still returned when it is all there is: the runner then reports the syntax error
    # with its line, which is the most useful feedback.
    ranked = sorted(
        range(len(defining)),
        key=lambda i: (_parses(defining[i][1]), defining[i][0], i),
    )
    chosen = defining[ranked[-1]][1]
    chosen = _with_helpers(
        chosen, [body for tag, body in blocks if tag in _PYTHON_TAGS and body is not chosen]
    )
    program = _drop_harmful_top_level(chosen)
    _check_signature(program, reply, entry)
    return program if program.endswith("\n") else program + "\n"


def _fix(entry: str) -> str:
    return f"answer with one ```python code block that defines {entry}"


def _parses(code: str) -> bool:
    try:
        ast.parse(code)
    except (SyntaxError, ValueError):
        return False
    return True


def _looks_like_code(text: str) -> bool:
    return bool(re.search(r"^\s*(def|import|from|return|for|if)\b.*", text, re.M)) and "(" in text


def _bare_code(reply: str) -> str | None:
    """Unfenced code: from the `def` of the entry point (with the `import`, `def` and comment lines just
    above it) down to the longest stretch that parses; prose before and after is left out."""
    lines = reply.splitlines()
    start = next((i for i, line in enumerate(lines) if _DEF.match(line)), None)
    if start is None:
        return None
    while start > 0 and re.match(r"^(import |from |def |class |#|@|\s+\S)", lines[start - 1]):
        start -= 1
    # shrink the end until the stretch parses (a trailing sentence of prose does not)
    for end in range(len(lines), start, -1):
        chunk = "\n".join(lines[start:end])
        if _DEF.search(chunk) and _parses(chunk):
            return chunk + "\n"
    # nothing parses: give the runner the whole tail so that it can point at the syntax error
    return "\n".join(lines[start:]) + "\n"


def _with_helpers(chosen: str, others: list[str]) -> str:
    """Prepend the functions that `chosen` calls but that the model defined in another block."""
    try:
        tree = ast.parse(chosen)
    except (SyntaxError, ValueError):
        return chosen
    defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
    helpers: list[str] = []
    for body in others:
        try:
            other = ast.parse(body)
        except (SyntaxError, ValueError):
            continue
        for node in other.body:
            if isinstance(node, ast.FunctionDef) and node.name in used - defined:
                helpers.append(ast.get_source_segment(body, node) or "")
                defined.add(node.name)
    return "\n\n".join([*helpers, chosen]) if helpers else chosen


def _drop_harmful_top_level(code: str) -> str:
    """Remove top-level `if __name__ == ...:` blocks and calls of the entry point: examples that the model
    added for a reader, which would fail (or be refused) when the program is loaded; and the API's classes
    (`class ImagePatch:`, `class Robot:`) copied from the prompt, which the runner provides (a program's
    own class of another name is left for the policy to judge)."""
    try:
        tree = ast.parse(code)
    except (SyntaxError, ValueError):
        return code
    lines = code.splitlines()
    drop: set[int] = set()
    for node in tree.body:
        harmful = False
        if isinstance(node, ast.If) and "__name__" in ast.unparse(node.test):
            harmful = True
        elif isinstance(node, ast.ClassDef) and node.name in API_CLASS_NAMES:
            harmful = True
        elif isinstance(node, ast.Expr | ast.Assign) and any(
            isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in (ENTRY_POINT, "print")
            for n in ast.walk(node)
        ):
            harmful = True
        if harmful:
            end = node.end_lineno or node.lineno
            start = min([node.lineno, *(d.lineno for d in getattr(node, "decorator_list", []))])
            drop.update(range(start - 1, end))
    return "\n".join(line for i, line in enumerate(lines) if i not in drop).rstrip() + "\n"


def _check_signature(program: str, reply: str, entry: str) -> None:
    """The entry point must take the arguments the runner gives it: (image, robot), or (image) alone as the
    paper's and ViperGPT's programs do (they build `Robot(...)` themselves)."""
    try:
        tree = ast.parse(program)
    except (SyntaxError, ValueError):
        return  # the runner reports the syntax error with its line
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == ENTRY_POINT:
            args = node.args
            positional = len(args.posonlyargs) + len(args.args)
            required = positional - len(args.defaults)
            if 1 <= positional and required <= 2 or args.vararg is not None:
                return
            raise NoProgram(
                f"{ENTRY_POINT} takes {positional} argument(s) ({required} required), "
                f"but it is called as {entry}",
                _fix(entry),
                reply=reply,
            )
    raise NoProgram(
        f"the code in the reply defines {ENTRY_POINT} only inside another block; define it at the top level",
        _fix(entry),
        reply=reply,
    )
