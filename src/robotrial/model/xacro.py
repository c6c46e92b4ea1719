"""xacro in: expand a `.xacro` file (or xacro text) to URDF text with the `xacro` package.

Layer 1. `$(find NAME)` and `package://` includes resolve through robotrial's package
search (model/packages.py), so xacro files work without a ROS install.

A description from someone else (an upload to the server) is expanded `confined` to its
own folder: it may not see the server. Refused, with the file, the line and the
substitution: `$(env ...)`, `$(cwd)`, `$(eval ...)` and `${...}` expressions that reach
beyond arithmetic on the file's own values, includes, `$(find ...)` and `load_yaml`
files outside the folder. `$(optenv NAME default)` gives its default. On the command
line, a user's own files keep xacro's full behaviour.
"""

from __future__ import annotations

import ast
import io
import math
import os
import re
import threading
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager, redirect_stderr
from pathlib import Path
from typing import Any

from robotrial.model.packages import PackageResolver, ResourceRefused
from robotrial.model.robot import ModelError

XACRO_SUFFIXES = (".xacro",)
XACRO_NS = "http://www.ros.org/wiki/xacro"

# xacro keeps its state in module globals: one expansion at a time.
_lock = threading.Lock()

# What a confined `${...}` or `$(eval ...)` may call: numbers in, numbers or text out.
SAFE_FUNCTIONS: dict[str, Any] = {
    **{k: v for k, v in math.__dict__.items() if not k.startswith("_")},
    **{
        f.__name__: f
        for f in (abs, bool, float, int, len, list, max, min, round, str, sum, tuple, dict)
    },
}
# Nodes of a Python expression that cannot reach outside the values they are given.
_SAFE_NODES = (
    ast.Expression,
    ast.BoolOp,
    ast.BinOp,
    ast.UnaryOp,
    ast.Compare,
    ast.IfExp,
    ast.Constant,
    ast.Name,
    ast.Load,
    ast.Call,
    ast.Attribute,
    ast.Subscript,
    ast.Slice,
    ast.Tuple,
    ast.List,
    ast.Dict,
    ast.keyword,
    ast.operator,
    ast.unaryop,
    ast.boolop,
    ast.cmpop,
)
# Namespaces xacro offers in expressions, and the names in them a confined file may use.
_XACRO_CALLS = {"arg", "load_yaml", "dotify", "tokenize"}  # load_yaml: confined like includes
_SAFE_ATTRIBUTES = {
    "math": set(SAFE_FUNCTIONS),
    "python": set(SAFE_FUNCTIONS),
    "xacro": _XACRO_CALLS,
}
_BIG_POWER = 64  # a larger constant exponent could exhaust the server's memory


def expand_xacro(
    path: str | Path,
    package_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    confined: Path | None = None,
) -> str:
    """The URDF text a xacro file expands to; ModelError (naming the file and what
    failed) if it does not. `confined`: the folder the file and everything it reads
    must stay in (see the module's docstring)."""
    import xacro

    p = Path(path).resolve()
    resolver = PackageResolver.create(p.parent, package_paths, confined=confined)
    with _lock, _xacro_hooks(resolver, p):
        try:
            doc = xacro.process_file(str(p), mappings=dict(xacro_args or {}))
        except Exception as exc:  # xacro raises XacroException, NameError, KeyError ...
            raise _failure(exc, _shown(p, confined)) from None
    return doc.toxml()


def expand_xacro_text(
    data: bytes,
    source: str,
    base_dir: Path,
    package_paths: Sequence[str | Path] = (),
    confined: Path | None = None,
) -> str:
    """The URDF text of xacro markup found inside a `.urdf` file (see expand_xacro)."""
    import xml.dom.minidom

    import xacro

    resolver = PackageResolver.create(base_dir, package_paths, confined=confined)
    with _lock, _xacro_hooks(resolver, Path(source)):
        try:
            xacro.init_stacks(source)
            doc = xml.dom.minidom.parseString(data)
            xacro.process_doc(doc)
        except Exception as exc:
            raise _failure(exc, source) from None
    return doc.toxml()


class ExpansionRefused(ModelError):
    """A confined expansion met a substitution or a file it may not use."""


def _failure(exc: BaseException, source: str) -> ModelError:
    """The error to raise: a refusal as it was made (xacro wraps it), else xacro's."""
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, ExpansionRefused):
            return ExpansionRefused(str(seen))
        seen = getattr(seen, "exc", None) or seen.__cause__ or seen.__context__
    return ModelError(f"{source}: xacro expansion failed: {_message(exc)}")


def _message(exc: BaseException) -> str:
    msg = str(exc).strip() or type(exc).__name__
    if isinstance(exc, KeyError):
        msg = f"undefined argument or key {msg} (pass it with xacro_args)"
    return " ".join(msg.split())


def _shown(path: Path, confined: Path | None) -> str:
    """A path as messages show it: relative to the confining folder, if any."""
    if confined is not None:
        try:
            return str(path.resolve().relative_to(confined.resolve()))
        except ValueError:
            pass
    return str(path)


class _Refusal:
    """Builds the refusal of one substitution, naming the file being expanded and the
    line the substitution stands on."""

    def __init__(self, confined: Path, first: Path) -> None:
        self.confined = confined
        self.first = first

    def __call__(self, what: str, why: str) -> ExpansionRefused:
        import xacro

        stack = getattr(xacro, "filestack", None) or [str(self.first)]
        current = Path(stack[-1] or self.first)
        return ExpansionRefused(f"{self.where(current, what)}: {what}: {why}")

    def where(self, file: Path, what: str) -> str:
        shown = _shown(file, self.confined)
        try:
            text = file.read_text(errors="replace")
        except OSError:
            return shown
        needle = what if what in text else what.split(" ")[0]
        at = text.find(needle)
        return f"{shown}:{text.count(chr(10), 0, at) + 1}" if at >= 0 else shown


def check_expression(expr: str) -> str | None:
    """Why a confined file may not evaluate the Python expression `expr` (None: it may):
    only arithmetic, comparisons, literals, its own names and SAFE_FUNCTIONS."""
    try:
        tree = ast.parse(expr.strip(), mode="eval")
    except SyntaxError:
        return None  # xacro reports the syntax error itself
    for node in ast.walk(tree):
        if not isinstance(node, _SAFE_NODES):
            return f"{type(node).__name__.lower()} is not allowed"
        if isinstance(node, ast.Name) and node.id.startswith("_"):
            return f"the name {node.id!r} is not allowed"
        if isinstance(node, ast.Attribute):
            base = node.value.id if isinstance(node.value, ast.Name) else None
            if node.attr not in _SAFE_ATTRIBUTES.get(base or "", set()):
                return f"the attribute {node.attr!r} is not allowed"
        if isinstance(node, ast.Call):
            f = node.func
            named = isinstance(f, ast.Name) and (f.id in SAFE_FUNCTIONS or f.id in _XACRO_CALLS)
            if not (named or isinstance(f, ast.Attribute)):
                return "only math functions, arg() and load_yaml() may be called"
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow | ast.LShift):
            r = node.right
            small = isinstance(r, ast.Constant) and isinstance(r.value, int | float)
            if not small or abs(r.value) > _BIG_POWER:
                return "powers and shifts must have a constant exponent of at most 64"
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            for side in (node.left, node.right):
                if isinstance(side, ast.List | ast.Tuple) or (
                    isinstance(side, ast.Constant) and isinstance(side.value, str)
                ):
                    return "repeating text or lists is not allowed"
    return None


@contextmanager
def _xacro_hooks(resolver: PackageResolver, first: Path) -> Iterator[None]:
    """xacro with robotrial's package search and, when the resolver is confined, the
    refusals of a confined expansion; xacro's messages become one warning."""
    import xacro
    from xacro import substitution_args as sa

    saved = {
        (sa, "_eval_find"): sa._eval_find,
        (sa, "_eval_env"): sa._eval_env,
        (sa, "_eval_optenv"): sa._eval_optenv,
        (sa, "_eval"): sa._eval,
        (xacro, "abs_filename_spec"): xacro.abs_filename_spec,
        (xacro, "eval_extension"): xacro.eval_extension,
        (xacro, "safe_eval"): xacro.safe_eval,
    }
    confined = resolver.confined
    refuse = _Refusal(confined, first) if confined is not None else None

    def find(name: str) -> str:
        candidates = resolver.package_candidates(name)
        if not candidates:
            if refuse is not None:
                raise refuse(f"$(find {name})", "no such package inside the uploaded files")
            searched = "; ".join(str(r) for r, _ in resolver.search_roots())
            raise ModelError(f"$(find {name}): package not found (searched: {searched})")
        return str(candidates[0])

    def abs_filename(spec: str) -> str:
        if spec.startswith(("package://", "file://")):
            try:
                return str(resolver.resolve(spec))
            except ResourceRefused as exc:
                assert refuse is not None
                raise refuse(spec, exc.reason) from None
        full = saved[(xacro, "abs_filename_spec")](spec)
        if refuse is not None:
            inside = Path(os.path.normpath(full))
            if not resolver.within(inside):
                raise refuse(spec, "the file is outside the uploaded files")
        return full

    sa._eval_find = find
    xacro.abs_filename_spec = abs_filename
    if refuse is not None:
        original_eval = saved[(sa, "_eval")]
        original_safe_eval = saved[(xacro, "safe_eval")]
        original_extension = saved[(xacro, "eval_extension")]

        def env(name: str) -> str:
            raise refuse(
                f"$(env {name})",
                "uploaded descriptions may not read the server's "
                "environment (use $(arg NAME) or a default with $(optenv NAME default))",
            )

        def optenv(name: str, default: str = "") -> str:
            return default

        def eval_(s: str, context: dict) -> str:
            why = check_expression(s)
            if why is not None:
                raise refuse(f"$(eval {s})", why)
            return original_eval(s, context)

        def safe_eval(expr: str, globals_: dict, locals_: Any = None) -> Any:
            why = check_expression(expr)
            if why is not None:
                raise refuse(f"${{{expr}}}", why)
            return original_safe_eval(expr, globals_, locals_)

        def extension(s: str) -> Any:
            if s == "$(cwd)":
                raise refuse("$(cwd)", "uploaded descriptions may not read the server's folders")
            return original_extension(s)

        sa._eval_env = env
        sa._eval_optenv = optenv
        sa._eval_dict.update(env=env, optenv=optenv)
        sa._eval = eval_
        xacro.safe_eval = safe_eval
        xacro.eval_extension = extension
    chatter = io.StringIO()
    try:
        with redirect_stderr(chatter):
            yield
    finally:
        for (module, name), value in saved.items():
            setattr(module, name, value)
        sa._eval_dict.update(env=saved[(sa, "_eval_env")], optenv=saved[(sa, "_eval_optenv")])
        text = " ".join(chatter.getvalue().split())
        if text:
            warnings.warn(f"xacro: {text}", UserWarning, stacklevel=4)


_SUBSTITUTION = re.compile(r"\$\((env|optenv)\s+([^)\s]+)(?:\s+([^)]*))?\)")


def default_optenv(text: str) -> tuple[str, list[str]]:
    """`text` with each `$(optenv NAME default)` left unexpanded (a URDF made by
    copying a xacro's output by hand) replaced by its default; the names replaced."""
    names: list[str] = []

    def sub(m: re.Match[str]) -> str:
        if m.group(1) != "optenv":
            return m.group(0)
        names.append(m.group(2))
        return m.group(3) or ""

    return _SUBSTITUTION.sub(sub, text), names
