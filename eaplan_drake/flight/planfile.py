"""Reader of the authors' plan files (``.pln``; paper 002 Appendix I, paper 003 data).

Format, one item per line, ``%`` starts a comment, blank lines are skipped:

- optionally first: the shift ``dx,dy`` [m] between repetitions (informational here);
- per stage: ``k_e;direction;φ(x, y, c1)`` then the triggering point ``x,y`` (expressions in c1);
  optionally followed by constraint sets ``[lo,hi]`` (paper 002; kept, not used). The last stage
  of ``dyn_plan_specification.pln`` has no triggering point: pass ``final_point=``.

``direction`` is 0 or 1 (paper 003 files) or 90 / 270 (paper 002, the rotation of E in degrees).
0 and 90 mean the field's rotation +E of the authors, which travels counter-clockwise around the
authors' circles (φ = (x − x_o)² + (y − y_o)² − R², gradient pointing out): our s = −1 (see
:mod:`eaplan_drake.flight.paths`: s = +1 is clockwise). 1 and 270 mean −E: s = +1. On the authors'
lines
this gives ``1;x+115`` travelling towards −y and ``0;x-35`` towards +y, as their survey flies.

Expressions are parsed by a small recursive-descent parser over a whitelisted grammar — numbers,
``x``, ``y``, ``c1``, ``+ - * / ^``, unary minus, ``sqrt( )`` and parentheses — never ``eval``.
Each path expression must be a line or a circle: φ = a(x² + y²) + b_x x + b_y y + c. The
expression is evaluated at the stage's c1 with x, y as ``pydrake.symbolic`` variables (its parts
free of x, y numerically) and its exact coefficients read from ``pydrake.symbolic.Polynomial``:
degree ≤ 2, equal x² and y² coefficients and no xy term; anything else (also sqrt, division or a
non-integer power of x or y) is rejected. The path function is then normalised (‖∇φ‖ = 1 on the
path, same zero set, direction and sign). An error names the file, line and column.

Gains: the authors' k_e (0.0003 for circles, 0.05 for lines) are tuned for their un-normalised φ
(a circle's φ grows like 2Rδ for a distance δ off it). Our guidance works on normalised φ, so every
stage gets our k_e (``k_e=`` argument, the scenario's ``GuidanceParams.k_e``); the file's value
is kept in :attr:`PlanStageSpec.file_k_e` for reference.
"""

import dataclasses as dc
import math
import re
from pathlib import Path

import numpy as np
from pydrake import symbolic as sym

from eaplan_drake.files import ReadTextFile
from eaplan_drake.flight.coverage import PlanSource
from eaplan_drake.flight.paths import PathFunction
from eaplan_drake.flight.stages import (
    ANCHOR_SIZE,
    APPROACH,
    NUM_PRIMITIVES,
    MakeStage,
    PathLength,
    Stage,
)
from eaplan_drake.packaged import PACKAGED_PLANS, PackagedPath

__all__ = [
    "PlanFileError",
    "Expression",
    "ParseExpression",
    "ParsePlanText",
    "PlanStageSpec",
    "PlanFile",
    "ReadPlanFile",
    "LoadPlanFile",
    "MakePlanFileSource",
    "REFERENCE_PLAN",
]

REFERENCE_PLAN = str(PACKAGED_PLANS["reference"])
"""The authors' static reference plan (``plan_specification.pln``), packaged."""


class PlanFileError(ValueError):
    """A plan file could not be read; the message names ``source:line:column``."""


# -- expressions --------------------------------------------------------------------------------

_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>[-+*/^()]))"
)
_VARIABLES = ("x", "y", "c1")
_FUNCTIONS = ("sqrt",)


MAX_EXPRESSION_TOKENS = 256
"""Longest expression [tokens]; with :data:`MAX_EXPRESSION_DEPTH` it bounds the depth of the
parser's and evaluator's recursion far below Python's limit."""
MAX_EXPRESSION_DEPTH = 32
"""Deepest nesting of parentheses in an expression [-]."""
MAX_PLAN_BYTES = 1_000_000
"""Largest plan file [bytes]."""
MAX_PLAN_SPECS = 10_000
"""Most stages in a plan file [-]."""


class _ExprError(Exception):
    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


def _Tokenize(text: str, col0: int) -> list[tuple[str, object, int]]:
    tokens = []
    pos = 0
    depth = 0
    text = text.rstrip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            bad = pos + (len(text[pos:]) - len(text[pos:].lstrip()))
            raise _ExprError(col0 + bad, f"unexpected character {text[bad]!r}")
        col = col0 + m.start(m.lastgroup)
        if m.group("num") is not None:
            tokens.append(("num", float(m.group("num")), col))
        elif m.group("name") is not None:
            name = m.group("name")
            if name not in _VARIABLES + _FUNCTIONS:
                allowed = ", ".join(_VARIABLES + _FUNCTIONS)
                raise _ExprError(col, f"unknown name {name!r} (allowed: {allowed})")
            tokens.append(("name", name, col))
        else:
            tokens.append(("op", m.group("op"), col))
        pos = m.end()
        if len(tokens) > MAX_EXPRESSION_TOKENS:
            raise _ExprError(col, f"expression longer than {MAX_EXPRESSION_TOKENS} tokens")
        if tokens[-1][:2] == ("op", "("):
            depth += 1
            if depth > MAX_EXPRESSION_DEPTH:
                raise _ExprError(col, f"parentheses nested deeper than {MAX_EXPRESSION_DEPTH}")
        elif tokens[-1][:2] == ("op", ")"):
            depth -= 1
    tokens.append(("end", None, col0 + len(text)))
    return tokens


class _Parser:
    """expr := term (('+'|'-') term)* ; term := unary (('*'|'/') unary)* ;
    unary := ('-'|'+') unary | power ; power := atom ('^' unary)? ;
    atom := number | x | y | c1 | sqrt '(' expr ')' | '(' expr ')'."""

    def __init__(self, tokens):
        self.tokens = tokens
        self.i = 0

    def peek(self):
        return self.tokens[self.i]

    def take(self):
        t = self.tokens[self.i]
        self.i += 1
        return t

    def expect(self, op: str):
        kind, value, col = self.take()
        if kind != "op" or value != op:
            found = "end of expression" if kind == "end" else repr(value)
            raise _ExprError(col, f"expected {op!r}, found {found}")

    def parse(self):
        node = self.expr()
        kind, value, col = self.peek()
        if kind != "end":
            raise _ExprError(col, f"unexpected {value!r} after a complete expression")
        return node

    def expr(self):
        node = self.term()
        while self.peek()[0] == "op" and self.peek()[1] in "+-":
            _, op, col = self.take()
            node = ("add" if op == "+" else "sub", col, node, self.term())
        return node

    def term(self):
        node = self.unary()
        while self.peek()[0] == "op" and self.peek()[1] in "*/":
            _, op, col = self.take()
            node = ("mul" if op == "*" else "div", col, node, self.unary())
        return node

    def unary(self):
        kind, value, col = self.peek()
        if kind == "op" and value in "+-":
            self.take()
            operand = self.unary()
            return ("neg", col, operand) if value == "-" else operand
        return self.power()

    def power(self):
        node = self.atom()
        if self.peek()[0] == "op" and self.peek()[1] == "^":
            _, _, col = self.take()
            node = ("pow", col, node, self.unary())
        return node

    def atom(self):
        kind, value, col = self.take()
        if kind == "num":
            return ("num", col, value)
        if kind == "name":
            if value == "sqrt":
                self.expect("(")
                node = self.expr()
                self.expect(")")
                return ("sqrt", col, node)
            return ("var", col, value)
        if kind == "op" and value == "(":
            node = self.expr()
            self.expect(")")
            return node
        found = "end of expression" if kind == "end" else repr(value)
        raise _ExprError(col, f"expected a number, x, y, c1, sqrt( or '(', found {found}")


def _Eval(node, env: dict) -> float:
    kind, col = node[0], node[1]
    if kind == "num":
        return node[2]
    if kind == "var":
        return env[node[2]]
    if kind == "neg":
        return -_Eval(node[2], env)
    if kind == "sqrt":
        v = _Eval(node[2], env)
        if v < 0.0:
            raise _ExprError(col, f"sqrt of a negative value ({v:g})")
        return math.sqrt(v)
    a = _Eval(node[2], env)
    b = _Eval(node[3], env)
    if kind == "add":
        return a + b
    if kind == "sub":
        return a - b
    if kind == "mul":
        return a * b
    if kind == "div":
        if b == 0.0:
            raise _ExprError(col, "division by zero")
        return a / b
    # pow
    if a < 0.0 and b != int(b):
        raise _ExprError(col, f"non-integer power {b:g} of a negative value ({a:g})")
    if a == 0.0 and b < 0.0:
        raise _ExprError(col, "zero to a negative power")
    try:
        v = a**b
    except OverflowError:
        raise _ExprError(col, "overflow in '^'") from None
    return float(v)


def _Uses(node, names: set) -> set:
    if node[0] == "var":
        names.add(node[2])
    for child in node[2:]:
        if isinstance(child, tuple):
            _Uses(child, names)
    return names


@dc.dataclass(frozen=True)
class Expression:
    """A parsed expression in x, y, c1 (see :func:`ParseExpression`)."""

    text: str
    tree: tuple
    variables: frozenset

    def __call__(self, x: float = 0.0, y: float = 0.0, c1: float = 0.0) -> float:
        """Value at (x, y, c1); raises ValueError naming the column on a domain error."""
        try:
            v = _Eval(self.tree, {"x": float(x), "y": float(y), "c1": float(c1)})
        except _ExprError as e:
            raise ValueError(f"column {e.col}: {e.message} in {self.text!r}") from None
        if not math.isfinite(v):
            raise ValueError(f"non-finite value in {self.text!r}")
        return v


def ParseExpression(text: str, col0: int = 1) -> Expression:
    """Parses ``text`` with the whitelisted grammar; ValueError names the column (1-based,
    offset by ``col0 − 1``)."""
    try:
        tree = _Parser(_Tokenize(text, col0)).parse()
    except _ExprError as e:
        raise ValueError(f"column {e.col}: {e.message}") from None
    except RecursionError:  # unreachable within the token and depth bounds; kept as a guard
        raise ValueError(f"column {col0}: expression nested too deeply") from None
    return Expression(text=text.strip(), tree=tree, variables=frozenset(_Uses(tree, set())))


# -- quadratic form -----------------------------------------------------------------------------


def _Polynomial(node, c1: float, x, y):
    """The expression tree as a ``pydrake.symbolic.Expression`` in the variables x, y at c1:
    sub-expressions free of x and y are evaluated numerically (with :func:`_Eval`'s domain
    checks); in x and y only +, −, ·, division by a constant and a constant non-negative integer
    power are allowed (a polynomial), anything else is not a line or a circle."""
    if not _Uses(node, set()) & {"x", "y"}:
        return sym.Expression(_Eval(node, {"x": 0.0, "y": 0.0, "c1": c1}))
    kind, col = node[0], node[1]
    if kind == "var":
        return x if node[2] == "x" else y
    if kind == "neg":
        return -_Polynomial(node[2], c1, x, y)
    if kind in ("add", "sub", "mul"):
        a, b = _Polynomial(node[2], c1, x, y), _Polynomial(node[3], c1, x, y)
        return a + b if kind == "add" else a - b if kind == "sub" else a * b
    if kind in ("div", "pow") and not _Uses(node[3], set()) & {"x", "y"}:
        v = _Eval(node[3], {"x": 0.0, "y": 0.0, "c1": c1})
        if kind == "div" and v != 0.0:
            return _Polynomial(node[2], c1, x, y) / v
        if kind == "pow" and v == int(v) and 0 <= v <= 2:
            return _Polynomial(node[2], c1, x, y) ** int(v)
    what = {"sqrt": "sqrt", "div": "division", "pow": "power"}[kind]
    raise _ExprError(
        col, f"not a line or a circle: a {what} of x or y (need a polynomial of degree <= 2)"
    )


def QuadraticForm(expression: Expression, c1: float = 0.0) -> tuple[float, float, float, float]:
    """(a, b_x, b_y, c), exactly, with ``expression``(x, y, c1) = a (x² + y²) + b_x x + b_y y + c
    (the coefficients of ``pydrake.symbolic.Polynomial`` in x, y); ValueError naming the column if
    the expression is not of that form at ``c1`` [m²]."""
    x, y = sym.Variable("x"), sym.Variable("y")
    try:
        e = _Polynomial(expression.tree, float(c1), x, y)
    except _ExprError as err:
        raise ValueError(f"column {err.col}: {err.message}") from None
    coefficients = {}
    for monomial, value in (
        sym.Polynomial(e, sym.Variables([x, y])).monomial_to_coefficient_map().items()
    ):
        degree = (monomial.degree(x), monomial.degree(y))
        if sum(degree) > 2:
            raise ValueError("not a line or a circle: a polynomial of degree > 2 in x, y")
        coefficients[degree] = float(value.Evaluate())
    axx, ayy = coefficients.get((2, 0), 0.0), coefficients.get((0, 2), 0.0)
    axy = coefficients.get((1, 1), 0.0)
    if axy != 0.0 or axx != ayy:
        raise ValueError(
            "not a line or a circle: need equal x² and y² coefficients and no x·y term "
            f"(got {axx:.6g} x², {ayy:.6g} y², {axy:.6g} x·y)"
        )
    return (
        axx,
        coefficients.get((1, 0), 0.0),
        coefficients.get((0, 1), 0.0),
        coefficients.get((0, 0), 0.0),
    )


# -- plan files ---------------------------------------------------------------------------------


@dc.dataclass(frozen=True)
class PlanStageSpec:
    """One stage as written in the file (expressions in c1)."""

    line: int
    """Line number of the stage in the file (1-based)."""
    file_k_e: float
    """The authors' gain for their un-normalised φ (not used for guidance)."""
    direction: int
    """As written: 0/1 or 90/270."""
    s: float
    """Our direction of travel (±1)."""
    path: Expression
    trigger: tuple[Expression, Expression] | None
    trigger_line: int
    bounds: tuple[tuple[float, float], ...] = ()
    """Constraint sets ``[lo,hi]`` listed after the stage (paper 002), if any."""


_DIRECTIONS = {0: -1.0, 90: -1.0, 1: 1.0, 270: 1.0}


class PlanFile(PlanSource):
    """A plan read from a ``.pln`` file, as a function of c1 (see module doc).

    Stage i is primitive −1 (approach) for i < ``approach_stages``, then
    (i − approach_stages) mod ``num_primitives``. Re-planning with a new c1 re-evaluates the stages
    after the current one from the file (the authors' semantics).

    Args:
        specs, shift: as :func:`ParsePlanText` returns them.
        source: the file's name in error messages.
        k_e: field gain of every stage [1/m].
        start: where the aircraft starts [m] (it sets the first stage's length).
        airspeed: v_a [m/s] the plan is flown at.
        initial_c1: c1 of the initial plan [m²], within ``c1_bounds``.
        c1_bounds: [c̲1, c̄1] [m²] over which the file's expressions are evaluated (both ends are
            checked here; errors name the line).
        final_point: triggering point (x, y) [m] of a last stage that has none in the file.
        num_primitives, approach_stages: the stage numbering above.
    """

    def __init__(
        self,
        specs,
        shift=None,
        *,
        source: str = "<plan>",
        k_e: float,
        start,
        airspeed: float,
        initial_c1: float,
        c1_bounds,
        final_point=None,
        num_primitives: int = NUM_PRIMITIVES,
        approach_stages: int = 1,
    ):
        self.specs = tuple(specs)
        self.shift = shift
        self.source = source
        if not self.specs:
            raise PlanFileError(f"{source}: no stages in the plan")
        self.k_e = float(k_e) if isinstance(k_e, int | float) else math.nan
        if not (math.isfinite(self.k_e) and self.k_e > 0):
            raise ValueError(f"PlanFile.k_e: must be > 0 1/m, got {k_e!r}")
        self.start = np.array(start, dtype=float).reshape(2)
        if not np.all(np.isfinite(self.start)):
            raise ValueError(f"PlanFile.start: must be a finite [x, y] in m, got {start!r}")
        self.final_point = None if final_point is None else tuple(float(v) for v in final_point)
        for spec in self.specs[:-1]:
            if spec.trigger is None:
                raise PlanFileError(f"{source}:{spec.line}: stage has no triggering point")
        if self.specs[-1].trigger is None and self.final_point is None:
            raise PlanFileError(
                f"{source}:{self.specs[-1].line}: the last stage has no triggering (final) point; "
                "pass final_point=(x, y)"
            )
        if not (isinstance(num_primitives, int) and num_primitives >= 1):
            raise ValueError(
                f"PlanFile.num_primitives: must be an integer >= 1, got {num_primitives}"
            )
        if not (isinstance(approach_stages, int) and 0 <= approach_stages <= len(self.specs)):
            raise ValueError(
                f"PlanFile.approach_stages: must be an integer in [0, {len(self.specs)}], "
                f"got {approach_stages}"
            )
        self.num_primitives = num_primitives
        self.approach_stages = approach_stages
        super().__init__(c1_bounds, initial_c1=initial_c1, airspeed=airspeed)
        # Both ends of the c1 range must give a valid plan (errors name the line).
        for c1 in set(self.c1_bounds):
            self.Stages(c1)

    def _Primitive(self, i: int) -> int:
        if i < self.approach_stages:
            return APPROACH
        return (i - self.approach_stages) % self.num_primitives

    def _Stages(self, c1: float) -> tuple[Stage, ...]:
        stages = []
        entry = self.start
        for i, spec in enumerate(self.specs):
            if spec.trigger is None:
                trig = np.array(self.final_point)
            else:
                try:
                    trig = np.array([spec.trigger[0](c1=c1), spec.trigger[1](c1=c1)])
                except ValueError as e:
                    raise PlanFileError(
                        f"{self.source}:{spec.trigger_line}: triggering point at c1 = {c1:g}: {e}"
                    ) from None
            try:
                if not spec.path.variables & {"x", "y"}:
                    raise ValueError("not a line or a circle: it does not depend on x or y")
                a, bx, by, c = QuadraticForm(spec.path, c1)
                path = PathFunction(a=a, b=(bx, by), c=c, s=spec.s, k_e=self.k_e).normalised()
                if path.is_circle:
                    path.radius  # noqa: B018  (raises if no real circle)
            except ValueError as e:
                raise PlanFileError(
                    f"{self.source}:{spec.line}: path {spec.path.text!r} at c1 = {c1:g}: {e}"
                ) from None
            proj = _Project(path, entry)
            length = PathLength(path, proj, trig)
            anchor = (c1,) + (0.0,) * (ANCHOR_SIZE - 1)
            stages.append(MakeStage(i, path, trig, self._Primitive(i), c1, proj, length, anchor))
            entry = trig
        return tuple(stages)

    def _StagesAfter(self, index: int, anchor, c1: float) -> tuple[Stage, ...]:
        return self.Stages(c1)[int(index) + 1 :]


def _Project(path: PathFunction, p) -> np.ndarray:
    """Closest point of ``path`` to p."""
    p = np.asarray(p, dtype=float)
    if path.is_circle:
        o = path.center
        v = p - o
        n = np.linalg.norm(v)
        if n == 0.0:
            return o + np.array([path.radius, 0.0])
        return o + path.radius * v / n
    g = np.asarray(path.b, dtype=float)
    return p - path.value(p) * g / float(g @ g)


def _SplitOutside(text: str, sep: str) -> list[tuple[str, int]]:
    """Splits at ``sep`` outside parentheses; returns (piece, 0-based start offset)."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif ch == sep and depth == 0:
            parts.append((text[start:i], start))
            start = i + 1
    parts.append((text[start:], start))
    return parts


def _Expr(piece: str, offset: int, source: str, line: int) -> Expression:
    lead = len(piece) - len(piece.lstrip())
    if not piece.strip():
        raise PlanFileError(f"{source}:{line}:{offset + 1}: empty expression")
    try:
        return ParseExpression(piece.strip(), col0=offset + lead + 1)
    except ValueError as e:
        msg = str(e)
        col = msg.split(":", 1)[0].replace("column ", "")
        raise PlanFileError(f"{source}:{line}:{col}: {msg.split(': ', 1)[1]}") from None


def _Pair(text: str, source: str, line: int, what: str, constant: bool = True):
    pieces = _SplitOutside(text, ",")
    if len(pieces) != 2:
        raise PlanFileError(
            f"{source}:{line}:1: {what} must be two comma-separated expressions 'x,y', "
            f"got {text.strip()!r}"
        )
    exprs = tuple(_Expr(p, off, source, line) for p, off in pieces)
    if constant:
        for e, (_, off) in zip(exprs, pieces, strict=True):
            bad = e.variables - {"c1"}
            if bad:
                raise PlanFileError(
                    f"{source}:{line}:{off + 1}: {what} may depend on c1 only, not on "
                    f"{', '.join(sorted(bad))}"
                )
    return exprs


def ParsePlanText(text: str, source: str = "<plan>"):
    """(specs, shift): the stages and the optional shift of a plan file's text."""
    specs: list[PlanStageSpec] = []
    shift = None
    pending = None  # a stage waiting for its triggering point
    for number, raw in enumerate(text.splitlines(), start=1):
        body = raw.split("%", 1)[0]
        if not body.strip():
            continue
        stripped = body.strip()
        if ";" in body:
            if pending is not None:
                raise PlanFileError(
                    f"{source}:{number}:1: stage of line {pending['line']} has no triggering point "
                    "(expected 'x,y' before the next stage)"
                )
            fields = body.split(";")
            if len(fields) != 3:
                raise PlanFileError(
                    f"{source}:{number}:1: a stage is 'k_e;direction;equation', got "
                    f"{len(fields)} ';'-separated fields"
                )
            offsets = [0, len(fields[0]) + 1, len(fields[0]) + len(fields[1]) + 2]
            k_e = _Expr(fields[0], offsets[0], source, number)
            if k_e.variables:
                raise PlanFileError(f"{source}:{number}:1: k_e must be a number")
            direction = fields[1].strip()
            col = offsets[1] + len(fields[1]) - len(fields[1].lstrip()) + 1
            if not re.fullmatch(r"\d+", direction) or int(direction) not in _DIRECTIONS:
                raise PlanFileError(
                    f"{source}:{number}:{col}: direction must be 0, 1, 90 or 270, got {direction!r}"
                )
            path = _Expr(fields[2], offsets[2], source, number)
            pending = {
                "line": number,
                "file_k_e": k_e(),
                "direction": int(direction),
                "s": _DIRECTIONS[int(direction)],
                "path": path,
            }
        elif stripped.startswith("["):
            if not stripped.endswith("]") or not specs or pending is not None:
                raise PlanFileError(
                    f"{source}:{number}:1: a constraint set '[lo,hi]' must follow a stage's "
                    "triggering point"
                )
            inner = body[body.index("[") + 1 : body.rindex("]")]
            lo, hi = _Pair(inner, source, number, "a constraint set")
            if lo.variables or hi.variables:
                raise PlanFileError(f"{source}:{number}:1: constraint sets must be numbers")
            specs[-1] = dc.replace(specs[-1], bounds=specs[-1].bounds + ((lo(), hi()),))
        else:
            if pending is None:
                if specs or shift is not None:
                    raise PlanFileError(
                        f"{source}:{number}:1: expected a stage 'k_e;direction;equation', got "
                        f"{stripped!r}"
                    )
                sx, sy = _Pair(body, source, number, "the shift")
                shift = (sx(), sy())
                continue
            trigger = _Pair(body, source, number, "a triggering point")
            specs.append(PlanStageSpec(trigger=trigger, trigger_line=number, **pending))
            pending = None
            if len(specs) > MAX_PLAN_SPECS:
                raise PlanFileError(f"{source}:{number}:1: more than {MAX_PLAN_SPECS} stages")
    if pending is not None:
        specs.append(PlanStageSpec(trigger=None, trigger_line=pending["line"], **pending))
    if not specs:
        raise PlanFileError(f"{source}: no stages in the plan")
    return specs, shift


def ReadPlanFile(path_or_text=None, *, text: str | None = None, **kwargs) -> PlanFile:
    """Reads a plan file (``path_or_text`` a path, None for the packaged reference plan; or
    ``text=``) into a :class:`PlanFile`; keyword arguments go to :class:`PlanFile` (``k_e``,
    ``start``, ``airspeed``, ``initial_c1``, ``c1_bounds`` are required there)."""
    if text is None:
        path = Path(REFERENCE_PLAN if path_or_text is None else path_or_text)
        if not path.is_file():
            raise PlanFileError(f"{path}: no such plan file")
        text, source = _ReadPlanText(path), str(path)
    else:
        source = "<text>"
    specs, shift = ParsePlanText(text, source)
    return PlanFile(specs, shift, source=source, **kwargs)


def _ReadPlanText(path: Path) -> str:
    return ReadTextFile(path, MAX_PLAN_BYTES, PlanFileError)


def LoadPlanFile(
    name_or_path: str, vehicle, *, c1: float, k_e: float, c1_bounds, **kwargs
) -> PlanFile:
    """A scenario's plan file: ``"reference"`` (or ``"reference_plan"``) is the packaged authors'
    plan, anything else a path. Start position and airspeed from ``vehicle``
    (:class:`~eaplan_drake.params.VehicleParams`), initial ``c1`` [m²], ``k_e`` [1/m] and
    ``c1_bounds`` [m²]; other keywords go to :class:`PlanFile`."""
    path = PackagedPath(PACKAGED_PLANS, name_or_path)
    return ReadPlanFile(
        path,
        k_e=k_e,
        start=vehicle.initial_position,
        airspeed=vehicle.airspeed,
        initial_c1=c1,
        c1_bounds=c1_bounds,
        **kwargs,
    )


def MakePlanFileSource(scenario, initial_c1: float) -> PlanFile:
    """The plan source of ``scenario``'s ``coverage.plan_file`` (an authors' ``.pln``; c1 over
    ``planner.path_parameter_bounds``), flown from ``vehicle.initial_position`` at
    ``vehicle.airspeed`` with the field gain ``guidance.k_e``, starting with ``initial_c1`` [m²].
    Raises ValueError (or OSError for the file)."""
    return LoadPlanFile(
        scenario.coverage.plan_file,
        scenario.vehicle,
        c1=initial_c1,
        k_e=scenario.guidance.k_e,
        c1_bounds=scenario.planner.path_parameter_bounds,
    )
