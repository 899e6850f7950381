"""The static half of the sandbox: parse a program, check it against an allow-list, and compile it with
the guards that stop one-operation bombs before they happen.

The check is one layer of several (the child process holds only stubs and harmless builtins, and runs
under resource limits); it is strict on purpose, and every refusal says what to write instead.
"""

from __future__ import annotations

import ast
import re
from types import CodeType

from attribot.runner.protocol import PROGRAM_FILENAME
from attribot.runner.records import Limits, RunError

__all__ = [
    "check_program",
    "names_sought",
    "prepare_program",
    "snippet_of",
    "DENIED_BUILTINS",
    "GUARD_NAMES",
]

DENIED_BUILTINS: frozenset[str] = frozenset(
    {
        "getattr",
        "setattr",
        "delattr",
        "hasattr",
        "type",
        "vars",
        "dir",
        "eval",
        "exec",
        "compile",
        "open",
        "globals",
        "locals",
        "input",
        "breakpoint",
        "memoryview",
        "object",
        "super",
        "id",
        "help",
        "exit",
        "quit",
        "classmethod",
        "staticmethod",
        "property",
        "format",
        "bytearray",
        "issubclass",
        "aiter",
        "anext",
        "copyright",
        "credits",
        "license",
    }
)
"""Builtins a program may not use (unless it binds the name itself, as `type = "cup"`): they reach
attributes by computed names, other modules, the file system or the interpreter's internals."""

DENIED_ATTRIBUTES: frozenset[str] = frozenset(
    # from_bytes: an integer of any size in one call, past the integer-size guard
    {"format", "format_map", "mro", "with_traceback", "throw", "send", "from_bytes"}
)
# generator, coroutine, async-generator, frame, traceback and code attributes: gi_frame, f_back, ...
_INTROSPECTION = re.compile(r"^(gi|cr|ag|tb|f|co)_")

# the guard functions the transform calls; their names start with "_" so no program can name them
GUARD_NAMES: dict[str, str] = {
    "pow": "_sb_pow",
    "mul": "_sb_mul",
    "lshift": "_sb_lshift",
    "ipow": "_sb_ipow",
    "imul": "_sb_imul",
    "ilshift": "_sb_ilshift",
    "add": "_sb_add",
    "iadd": "_sb_iadd",
    "slice": "_sb_slice",
}
# `+` is guarded too: repeated concatenation (`s = s + s`) grows a sequence as fast as `*` does
_BINOP_GUARD = {ast.Pow: "pow", ast.Mult: "mul", ast.LShift: "lshift", ast.Add: "add"}
_AUG_GUARD = {ast.Pow: "ipow", ast.Mult: "imul", ast.LShift: "ilshift", ast.Add: "iadd"}

_ALLOWED: tuple[type[ast.AST], ...] = (
    ast.Module,
    ast.FunctionDef,
    ast.Return,
    ast.Delete,
    ast.Assign,
    ast.AugAssign,
    ast.AnnAssign,
    ast.For,
    ast.While,
    ast.If,
    ast.Raise,
    ast.Assert,
    ast.Import,
    ast.ImportFrom,
    ast.Try,
    ast.ExceptHandler,
    ast.Expr,
    ast.Pass,
    ast.Break,
    ast.Continue,
    ast.BoolOp,
    ast.NamedExpr,
    ast.BinOp,
    ast.UnaryOp,
    ast.Lambda,
    ast.IfExp,
    ast.Dict,
    ast.Set,
    ast.ListComp,
    ast.SetComp,
    ast.DictComp,
    ast.GeneratorExp,
    ast.Compare,
    ast.Call,
    ast.FormattedValue,
    ast.JoinedStr,
    ast.Constant,
    ast.Attribute,
    ast.Subscript,
    ast.Starred,
    ast.Name,
    ast.List,
    ast.Tuple,
    ast.Slice,
    ast.expr_context,
    ast.boolop,
    ast.operator,
    ast.unaryop,
    ast.cmpop,
    ast.comprehension,
    ast.arguments,
    ast.arg,
    ast.keyword,
    ast.alias,
)

_REFUSED: dict[type[ast.AST], str] = {
    ast.ClassDef: "classes are not allowed: write plain functions",
    ast.AsyncFunctionDef: "async functions are not allowed",
    ast.AsyncFor: "async for is not allowed",
    ast.AsyncWith: "async with is not allowed",
    ast.Await: "await is not allowed",
    ast.With: "with statements are not allowed",
    ast.Global: "global is not allowed: return values from functions instead",
    ast.Nonlocal: "nonlocal is not allowed: return values from functions instead",
    ast.Yield: "yield is not allowed: build and return a list instead",
    ast.YieldFrom: "yield from is not allowed: build and return a list instead",
    ast.Match: "match statements are not allowed: use if/elif",
}
if hasattr(ast, "TryStar"):  # Python 3.11+
    _REFUSED[ast.TryStar] = "try/except* is not allowed: write `except ActionFailed as error:`"

CATCHABLE = "ActionFailed"
"""The one error a program may catch: an action or measurement that ran and failed in the world."""
_CATCH_ONLY = (
    "catch only ActionFailed, the error of a robot action or measurement that failed in the world "
    "(`except ActionFailed as error:` then go on with the next object); other errors are the program's "
    "to fix, and the runner reports them"
)
# what to write instead of a refused builtin
_INSTEAD: dict[str, str] = {
    "format": 'use an f-string, e.g. f"{value:.2f}"',
    "getattr": "read the attribute by its name, e.g. patch.horizontal_center",
    "hasattr": "the API's attributes are listed in its reference; read them by name",
    "setattr": "keep values in variables or dicts",
    "type": "use isinstance(value, ImagePatch) (or int, float, str, list, ...)",
    "dir": "the API's attributes and methods are listed in its reference",
    "vars": "keep values in variables or dicts",
    "open": "programs cannot read or write files; return the answer instead",
    "input": "programs cannot read input; everything they need comes from image and robot",
    "eval": "write the code itself",
    "exec": "write the code itself",
    "compile": "write the code itself",
    "exit": "return from execute_command instead",
    "quit": "return from execute_command instead",
}


class _Refusal(Exception):
    def __init__(self, node: ast.AST | None, message: str, category: str = "policy") -> None:
        super().__init__(message)
        self.line = getattr(node, "lineno", None)
        self.message = message
        self.category = category


def snippet_of(source: str, line: int | None) -> str | None:
    """The program's line `line` (1-based), trimmed, for error reports; None when there is none."""
    if line is None or line < 1:
        return None
    lines = source.splitlines()
    if line > len(lines):
        return None
    text = lines[line - 1].rstrip()
    return text if len(text) <= 200 else text[:197] + "..."


def _bound_names(tree: ast.AST) -> set[str]:
    """Every name the program binds anywhere: a program may call its own variable `type` or `id`."""
    bound: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store | ast.Del):
            bound.add(node.id)
        elif isinstance(node, ast.FunctionDef):
            bound.add(node.name)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, ast.alias):
            bound.add((node.asname or node.name).split(".")[0])
        elif isinstance(node, ast.ExceptHandler) and node.name:
            bound.add(node.name)
    return bound


def _binding_of(tree: ast.AST, name: str) -> ast.AST | None:
    """The first node that binds `name` (for the line of a refusal)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and not isinstance(node.ctx, ast.Load):
            names = {node.id}
        elif isinstance(node, ast.alias):
            names = {(node.asname or node.name).split(".")[0]}
        else:
            names = {str(getattr(node, "name", "")), str(getattr(node, "arg", ""))}
        if name in names:
            return node
    return None


def _check_name(node: ast.AST, name: str, what: str) -> None:
    if name.startswith("_") and name != "_":
        raise _Refusal(
            node,
            f"{what} {name!r}: names starting with '_' are not allowed; rename it "
            f"(e.g. {name.strip('_') or 'value'!r})",
        )


def _is_main_block(node: ast.stmt) -> bool:
    """`if __name__ == "__main__":` (either way round), which never runs when the runner loads a program."""
    if not isinstance(node, ast.If) or not isinstance(node.test, ast.Compare):
        return False
    test = node.test
    if len(test.ops) != 1 or not isinstance(test.ops[0], ast.Eq):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s for s in sides if isinstance(s, ast.Name) and s.id == "__name__"]
    mains = [s for s in sides if isinstance(s, ast.Constant) and s.value == "__main__"]
    return len(names) == 1 and len(mains) == 1


def _check_try(node: ast.Try) -> None:
    """A try/except is allowed around API calls only to catch ActionFailed, with no `finally` (which
    could end a stop) and no other exception type."""
    if node.finalbody:
        raise _Refusal(node, f"try/finally is not allowed: {_CATCH_ONLY}")
    for handler in node.handlers:
        caught = handler.type
        names = caught.elts if isinstance(caught, ast.Tuple) else [caught]
        for name in names:
            if not (isinstance(name, ast.Name) and name.id == CATCHABLE):
                what = f"`except {ast.unparse(caught)}:`" if caught is not None else "a bare `except:`"
                raise _Refusal(handler, f"{what} is not allowed: {_CATCH_ONLY}")
        if handler.name is not None:
            _check_name(handler, handler.name, "name")


def _check_import(node: ast.Import | ast.ImportFrom) -> None:
    """`import math` and, as annotations only, `typing` and `from __future__ import annotations`."""
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name not in ("math", "typing"):
                raise _Refusal(node, f"import {alias.name}: {_IMPORTS}")
            if alias.asname:
                _check_name(node, alias.asname, "name")
        return
    module = node.module or ""
    if node.level or module not in ("math", "typing", "__future__"):
        raise _Refusal(node, f"from {'.' * node.level}{module} import ...: {_IMPORTS}")
    for alias in node.names:
        if alias.name == "*":
            raise _Refusal(node, f"from {module} import *: name what you need")
        if module == "__future__" and alias.name != "annotations":
            raise _Refusal(node, f"from __future__ import {alias.name}: only annotations is allowed")
        _check_name(node, alias.name, "name")
        if alias.asname:
            _check_name(node, alias.asname, "name")


_IMPORTS = (
    "only `import math` is allowed (and typing, for annotations); compute with math and the built-ins "
    "(sum, min, max, sorted, abs, round)"
)


def _check_tree(tree: ast.Module) -> None:
    bound = _bound_names(tree)
    if CATCHABLE in bound:  # `ActionFailed = Exception` would make `except ActionFailed` catch anything
        raise _Refusal(
            _binding_of(tree, CATCHABLE),
            f"{CATCHABLE} is the API's error and cannot be rebound: give the variable another name",
        )
    for node in ast.walk(tree):
        kind = type(node)
        if kind in _REFUSED:
            raise _Refusal(node, _REFUSED[kind])
        if not isinstance(node, _ALLOWED):
            raise _Refusal(node, f"{kind.__name__} is not allowed in programs")
        if isinstance(node, ast.Name):
            _check_name(node, node.id, "name")
            if node.id in DENIED_BUILTINS and node.id not in bound:
                instead = _INSTEAD.get(node.id)
                raise _Refusal(
                    node, f"{node.id}() is not available in programs" + (f": {instead}" if instead else "")
                )
        elif isinstance(node, ast.Attribute):
            _check_name(node, node.attr, "attribute")
            if node.attr in DENIED_ATTRIBUTES or _INTROSPECTION.match(node.attr):
                instead = _INSTEAD["format"] if node.attr in ("format", "format_map") else None
                raise _Refusal(
                    node,
                    f"the attribute .{node.attr} is not allowed in programs"
                    + (f": {instead}" if instead else ""),
                )
            if not isinstance(node.ctx, ast.Load):
                raise _Refusal(node, "attributes are read-only in programs: keep values in variables")
        elif isinstance(node, ast.FunctionDef):
            _check_name(node, node.name, "function")
            if node.decorator_list:
                raise _Refusal(node, "decorators are not allowed")
        elif isinstance(node, ast.arg):
            _check_name(node, node.arg, "argument")
        elif isinstance(node, ast.keyword) and node.arg is not None:
            _check_name(node, node.arg, "keyword argument")
        elif isinstance(node, ast.comprehension) and node.is_async:
            raise _Refusal(node.target, "async comprehensions are not allowed")
        elif isinstance(node, ast.Import | ast.ImportFrom):
            _check_import(node)
        elif isinstance(node, ast.Try):
            _check_try(node)
        elif isinstance(node, ast.Delete):
            for target in node.targets:
                if isinstance(target, ast.Attribute):
                    raise _Refusal(node, "attributes are read-only in programs")


def _guard(name: str, node: ast.AST) -> ast.Name:
    return ast.copy_location(ast.Name(id=GUARD_NAMES[name], ctx=ast.Load()), node)


class _Guards(ast.NodeTransformer):
    """`a ** b`, `a * b`, `a << b`, `a + b` (and their augmented forms) become calls of guard functions
    that check the size of the result before computing it; annotations are dropped (never evaluated)."""

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:  # noqa: N802 (ast visitor API)
        self.generic_visit(node)
        guard = _BINOP_GUARD.get(type(node.op))
        if guard is None:
            return node
        call = ast.Call(func=_guard(guard, node), args=[node.left, node.right], keywords=[])
        return ast.copy_location(call, node)

    def visit_AugAssign(self, node: ast.AugAssign) -> ast.AST | list[ast.stmt]:  # noqa: N802
        self.generic_visit(node)
        guard = _AUG_GUARD.get(type(node.op))
        if guard is None:
            return node
        target = node.target
        if isinstance(target, ast.Name):
            read = ast.Name(id=target.id, ctx=ast.Load())
            call = ast.Call(func=_guard(guard, node), args=[read, node.value], keywords=[])
            return ast.copy_location(ast.Assign(targets=[target], value=call), node)
        if isinstance(target, ast.Subscript):
            # evaluate the container and the key once, as `a[k] op= v` does
            key: ast.expr = target.slice
            if isinstance(key, ast.Slice):
                key = ast.Call(
                    func=_guard("slice", node),
                    args=[
                        key.lower or ast.Constant(None),
                        key.upper or ast.Constant(None),
                        key.step or ast.Constant(None),
                    ],
                    keywords=[],
                )
            obj_name, key_name = "_sb_obj", "_sb_key"
            stmts: list[ast.stmt] = [
                ast.Assign(targets=[ast.Name(id=obj_name, ctx=ast.Store())], value=target.value),
                ast.Assign(targets=[ast.Name(id=key_name, ctx=ast.Store())], value=key),
                ast.Assign(
                    targets=[
                        ast.Subscript(
                            value=ast.Name(id=obj_name, ctx=ast.Load()),
                            slice=ast.Name(id=key_name, ctx=ast.Load()),
                            ctx=ast.Store(),
                        )
                    ],
                    value=ast.Call(
                        func=_guard(guard, node),
                        args=[
                            ast.Subscript(
                                value=ast.Name(id=obj_name, ctx=ast.Load()),
                                slice=ast.Name(id=key_name, ctx=ast.Load()),
                                ctx=ast.Load(),
                            ),
                            node.value,
                        ],
                        keywords=[],
                    ),
                ),
            ]
            return [ast.fix_missing_locations(ast.copy_location(s, node)) for s in stmts]
        return node  # attribute targets are refused by the check

    def visit_arg(self, node: ast.arg) -> ast.AST:  # noqa: N802
        node.annotation = None
        return node

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:  # noqa: N802
        self.generic_visit(node)
        node.returns = None
        return node

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.AST:  # noqa: N802
        self.generic_visit(node)
        if node.value is None:
            return ast.copy_location(ast.Pass(), node)
        return ast.copy_location(ast.Assign(targets=[node.target], value=node.value), node)


def _parse(source: str, entry: str, limits: Limits) -> ast.Module:
    if not isinstance(source, str):
        raise _Refusal(None, f"the program must be a str, got {type(source).__name__}", "syntax")
    if len(source) > limits.max_source_chars:
        raise _Refusal(
            None,
            f"the program is {len(source)} characters long; at most {limits.max_source_chars} are allowed",
            "limit",
        )
    try:
        tree = ast.parse(source, filename=PROGRAM_FILENAME)
    except SyntaxError as e:
        err = _Refusal(None, e.msg or "invalid syntax", "syntax")
        err.line = e.lineno
        raise err from None
    except (ValueError, RecursionError, MemoryError) as e:  # null bytes, absurd nesting
        msg = "the program is nested too deeply" if not isinstance(e, ValueError) else str(e)
        raise _Refusal(None, msg, "syntax") from None
    # the block never runs when the runner loads the program (its __name__ is not "__main__"), as in Python
    tree.body = [node for node in tree.body if not _is_main_block(node)]
    _check_tree(tree)
    if not any(isinstance(n, ast.FunctionDef) and n.name == entry for n in tree.body):
        raise _Refusal(None, f"the program must define `def {entry}(...)` at the top level", "syntax")
    return tree


def names_sought(source: str, limits: Limits | None = None) -> frozenset[str]:
    """The object names a program looks for: the literal first arguments of its `.find(...)` and
    `.exists(...)` calls ("mug" of `image.find("mug")`), stripped and lower-cased. Empty for a program
    that does not parse or is longer than `limits` allow (the runner refuses it and says why)."""
    if not isinstance(source, str) or len(source) > (limits or Limits()).max_source_chars:
        return frozenset()
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return frozenset()
    names = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in ("find", "exists")
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
            and node.args[0].value.strip()
        ):
            names.add(" ".join(node.args[0].value.lower().split()))
    return frozenset(names)


def _as_error(refusal: _Refusal, source: str) -> RunError:
    return RunError(
        category=refusal.category,
        message=refusal.message,
        line=refusal.line,
        snippet=snippet_of(source, refusal.line) if isinstance(source, str) else None,
        output="",
    )


def check_program(
    source: str, entry: str = "execute_command", limits: Limits | None = None
) -> RunError | None:
    """The static policy check alone: None when `source` may run, else the syntax or policy error."""
    try:
        _parse(source, entry, limits or Limits())
    except _Refusal as r:
        return _as_error(r, source)
    return None


def prepare_program(
    source: str, entry: str = "execute_command", limits: Limits | None = None
) -> tuple[CodeType | None, RunError | None]:
    """Check `source` and compile it with the bomb guards: (code, None) or (None, error)."""
    try:
        tree = _parse(source, entry, limits or Limits())
    except _Refusal as r:
        return None, _as_error(r, source)
    try:
        tree = ast.fix_missing_locations(_Guards().visit(tree))
        code = compile(tree, PROGRAM_FILENAME, "exec", dont_inherit=True)
    except (SyntaxError, ValueError, RecursionError, MemoryError) as e:
        line = getattr(e, "lineno", None)
        msg = getattr(e, "msg", None) or "the program is nested too deeply"
        return None, RunError(category="syntax", message=msg, line=line, snippet=snippet_of(source, line))
    return code, None
