"""The typed syntax tree of the preprocessed GLSL the snippets are made of, its parser and its
GLSL printer.

The GLSL is the library's subset after specialisation (:mod:`cellgl.export.translate`: no
directive, no macro): structs, global constants and uniforms, functions (and prototypes), the
statements ``{}``, declarations, expressions, ``if``/``else``, ``for``, ``while``, ``return``,
``break``/``continue``/``discard``, and the expressions of GLSL without the comma operator.

Comments stay on their nodes: the comment lines above a top-level declaration, a statement or a
struct member are its ``comments`` (``""`` for a blank line between comment blocks), a ``//``
comment after a statement on its line its ``trail``. ``print_glsl`` writes a tree back as
GLSL (:mod:`cellgl.export.printer`: 4-space indentation, the comments where they were,
parentheses as written: a :class:`Paren` is the source's own).

:func:`parsed_library` caches the tree of a specialised library per process: an export parses
each library text once.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

from cellgl.export.translate.tokens import GLSL_TYPES, TranslateError, split_tokens


# --------------------------------------------------------------------------------------------
# nodes
# --------------------------------------------------------------------------------------------

#: The node classes, written out so type checkers and editors see them. Each class's fields are in
#: source order (the order a walk visits them); a field typed ``object`` is a node, or None where it
#: may be absent; a ``list`` defaults to a fresh list. ``comments``: the comment lines above the node;
#: ``trail``: the ``//`` comment after it on its line (a Block's: after its opening brace);
#: ``same_line``: written on the line of the statement before it.

@dataclass
class Num:  # as written: 1.0, 0x9e3779b9u, 3e-5
    text: str


@dataclass
class Name:
    name: str


@dataclass
class Call:
    func: str
    args: list


@dataclass
class Ctor:  # vec4(...), CellglResult(...)
    type: str
    args: list


@dataclass
class ArrayCtor:  # float[3](a, b, c)
    type: str
    size: object
    args: list


@dataclass
class Unary:  # - + ! ~
    op: str
    operand: object


@dataclass
class IncDec:  # ++ --
    op: str
    operand: object
    postfix: bool


@dataclass
class Binary:
    op: str
    left: object
    right: object


@dataclass
class Assign:  # = += -= ...
    op: str
    target: object
    value: object


@dataclass
class Ternary:
    cond: object
    then: object
    other: object


@dataclass
class Index:
    base: object
    index: object


@dataclass
class Member:
    base: object
    name: str


@dataclass
class Paren:
    inner: object


@dataclass
class Declarator:  # size: an array's size expression
    name: str
    size: object = None
    init: object = None


@dataclass
class Block:
    body: list
    comments: list = field(default_factory=list)
    trail: str = ""


@dataclass
class Decl:
    type: str
    declarators: list
    const: bool = False
    comments: list = field(default_factory=list)
    trail: str = ""
    same_line: bool = False


@dataclass
class ExprStmt:
    expr: object
    comments: list = field(default_factory=list)
    trail: str = ""
    same_line: bool = False


@dataclass
class If:
    cond: object
    then: object
    other: object = None
    comments: list = field(default_factory=list)


@dataclass
class For:  # init: a Decl, an ExprStmt or None
    init: object
    cond: object
    step: object
    body: object
    comments: list = field(default_factory=list)


@dataclass
class While:
    cond: object
    body: object
    comments: list = field(default_factory=list)


@dataclass
class Return:
    value: object = None
    comments: list = field(default_factory=list)


@dataclass
class Jump:  # break continue discard
    kind: str
    comments: list = field(default_factory=list)


@dataclass
class Field:
    type: str
    name: str
    size: object = None
    comments: list = field(default_factory=list)
    trail: str = ""


@dataclass
class Struct:
    name: str
    fields: list
    comments: list = field(default_factory=list)


@dataclass
class Param:  # mode: in out inout
    mode: str
    type: str
    name: str
    size: object = None
    const: bool = False


@dataclass
class Function:  # body None: a prototype
    ret: str
    name: str
    params: list
    body: object
    comments: list = field(default_factory=list)


@dataclass
class Global:  # quals: const, uniform (no precision ones)
    quals: list
    type: str
    declarators: list
    comments: list = field(default_factory=list)


@dataclass
class Unit:  # trailing: the comments after the last item
    items: list
    trailing: list = field(default_factory=list)


NODE_CLASSES = (Num, Name, Call, Ctor, ArrayCtor, Unary, IncDec, Binary, Assign, Ternary, Index,
                Member, Paren, Declarator, Block, Decl, ExprStmt, If, For, While, Return, Jump,
                Field, Struct, Param, Function, Global, Unit)

__all__ = ["parse", "parsed_library", "NODE_CLASSES", *(c.__name__ for c in NODE_CLASSES)]


# --------------------------------------------------------------------------------------------
# parser: recursive descent over the code tokens
# --------------------------------------------------------------------------------------------

_ASSIGN_OPS = {"=", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=", "<<=", ">>="}
BINARY_PRECEDENCE = [("||",), ("^^",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="),
                     ("<", ">", "<=", ">="), ("<<", ">>"), ("+", "-"), ("*", "/", "%")]
PRECEDENCE = {op: level for level, ops in enumerate(BINARY_PRECEDENCE) for op in ops}
_PRECISION = ("highp", "mediump", "lowp")


class _Parser:
    def __init__(self, text: str):
        self.toks: list[tuple[str, str, list[str]]] = []   # (kind, text, comments before it)
        self.trail: dict[int, str] = {}     # token index -> comment on the rest of its line
        self.inline: set[int] = set()       # the tokens that do not begin their line
        pending: list[str] = []
        newline = fresh = True              # fresh: no code token on this line yet
        for kind, tt in split_tokens(text):
            if kind == "comment" and not newline and self.toks and tt.startswith("//") \
                    and len(self.toks) - 1 not in self.trail:
                self.trail[len(self.toks) - 1] = tt
                continue
            if kind != "ws":
                newline = False
            elif "\n" in tt:
                newline = fresh = True
            if kind == "comment":
                pending.append(tt)
            elif kind == "ws":
                if tt.count("\n") >= 2 and pending and pending[-1] != "":
                    pending.append("")          # one blank line between comment blocks
            else:
                if not fresh:
                    self.inline.add(len(self.toks))
                self.toks.append((kind, tt, pending))
                pending = []
                fresh = False
        self.trailing = pending
        self.i = 0
        self.structs: set[str] = set()

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.toks[j][1] if j < len(self.toks) else ""

    def kind(self, k: int = 0) -> str:
        j = self.i + k
        return self.toks[j][0] if j < len(self.toks) else ""

    def comments(self) -> list[str]:
        return list(self.toks[self.i][2]) if self.i < len(self.toks) else []

    def take(self, want: str | None = None) -> str:
        if self.i >= len(self.toks):
            raise TranslateError(f"unexpected end of shader text (expected {want!r})")
        t = self.toks[self.i][1]
        if want is not None and t != want:
            ctx = " ".join(x[1] for x in self.toks[max(0, self.i - 8): self.i + 4])
            raise TranslateError(f"GLSL syntax: expected {want!r}, got {t!r} near: {ctx}")
        self.i += 1
        return t

    def accept(self, t: str) -> bool:
        """Whether the next token is ``t`` (then taken)."""
        ok = self.peek() == t
        self.i += ok
        return ok

    def upto(self, parse, closing: str):
        """``parse()`` (None where the next token is ``closing``), then ``closing`` taken."""
        e = None if self.peek() == closing else parse()
        self.take(closing)
        return e

    def is_type(self, k: int = 0) -> bool:
        t = self.peek(k)
        return t in GLSL_TYPES or t in self.structs

    def qualifiers(self, *allowed: str) -> list[str]:
        """The qualifiers among ``allowed`` at the cursor, taken (precision qualifiers too, dropped)."""
        out = []
        while self.peek() in allowed or self.peek() in _PRECISION:
            q = self.take()
            if q not in _PRECISION:
                out.append(q)
        return out

    # top level
    def unit(self) -> Unit:
        out = []
        while self.i < len(self.toks):
            com = self.comments()
            if self.peek() == "struct":
                out.append(self.struct(com))
                continue
            quals = self.qualifiers("const", "uniform", "in", "out", "flat")
            typ = self.take()
            if self.peek() == "[":
                raise TranslateError(f"GLSL syntax: array types in 'T[N] name' form are not supported ({typ}[...])")
            name = self.take()
            if self.peek() == "(":
                out.append(self.function(com, typ, name))
            else:
                out.append(Global(quals, typ, self.declarators(name), com))
                self.take(";")
        return Unit(out, self.trailing)

    def struct(self, com) -> Struct:
        self.take("struct")
        name = self.take()
        self.structs.add(name)
        self.take("{")
        fields = []
        while self.peek() != "}":
            fcom = self.comments()
            self.qualifiers()
            typ = self.take()
            fields.append(Field(typ, self.take(), self.array_size(), fcom))
            while self.accept(","):
                fields.append(Field(typ, self.take(), self.array_size()))
            self.take(";")
            fields[-1].trail = self.trail.get(self.i - 1, "")
        self.take("}")
        self.take(";")
        return Struct(name, fields, com)

    def function(self, com, ret: str, name: str) -> Function:
        self.take("(")
        params = []
        while self.peek() != ")":
            quals = self.qualifiers("in", "out", "inout", "const")
            mode = ([q for q in quals if q in ("out", "inout")] or ["in"])[-1]
            ptyp = self.take()
            if ptyp == "void" and self.peek() == ")":
                break
            params.append(Param(mode, ptyp, self.take(), self.array_size(), "const" in quals))
            self.accept(",")
        self.take(")")
        return Function(ret, name, params, None if self.accept(";") else self.block(), com)

    def array_size(self):
        return self.inside("[", "]") if self.peek() == "[" else None

    def inside(self, opening: str, closing: str):
        """The expression between the brackets ``opening`` and ``closing``."""
        self.take(opening)
        e = self.expr()
        self.take(closing)
        return e

    def declarators(self, name: str) -> list:
        """The declarators from the one named ``name`` (taken) on: ``a[2], b = 1.0``."""
        decls = []
        while True:
            size = self.array_size()
            decls.append(Declarator(name, size, self.assign_expr() if self.accept("=") else None))
            if not self.accept(","):
                return decls
            name = self.take()

    # statements
    def block(self, com=None) -> Block:
        self.take("{")
        trail = self.trail.get(self.i - 1, "")
        out = []
        while self.peek() != "}":
            out.append(self.statement())
        self.take("}")
        return Block(out, com or [], trail)

    def statement(self):
        com = self.comments()
        t = self.peek()
        if t == "{":
            return self.block(com)
        if t == "if":
            self.take()
            c = self.inside("(", ")")
            a = self.statement()
            return If(c, a, self.statement() if self.accept("else") else None, com)
        if t == "for":
            self.take()
            self.take("(")
            init, cond = self.upto(self.simple_statement, ";"), self.upto(self.expr, ";")
            return For(init, cond, self.upto(self.expr, ")"), self.statement(), com)
        if t == "while":
            self.take()
            return While(self.inside("(", ")"), self.statement(), com)
        if t == "return":
            self.take()
            return Return(self.upto(self.expr, ";"), com)
        if t in ("break", "continue", "discard"):
            self.take()
            self.take(";")
            return Jump(t, com)
        if self.accept(";"):
            return Block([], com)
        same_line = self.i in self.inline and self.peek(-1) == ";"
        s = self.simple_statement()
        self.take(";")
        s.comments = com
        s.trail = self.trail.get(self.i - 1, "")
        s.same_line = same_line
        return s

    def simple_statement(self):
        const = "const" in self.qualifiers("const")
        if self.is_type() and self.kind(1) == "id":
            typ = self.take()
            return Decl(typ, self.declarators(self.take()), const)
        return ExprStmt(self.expr())

    # expressions
    def expr(self):
        e = self.assign_expr()
        if self.peek() == ",":
            raise TranslateError("GLSL syntax: the comma operator is not supported")
        return e

    def assign_expr(self):
        lhs = self.ternary()
        if self.peek() in _ASSIGN_OPS:
            op = self.take()
            return Assign(op, lhs, self.assign_expr())
        return lhs

    def ternary(self):
        c = self.climb(self.unary(), 0)
        if self.accept("?"):
            a = self.assign_expr()
            self.take(":")
            return Ternary(c, a, self.assign_expr())
        return c

    def climb(self, left, level: int):
        """The binary expression that starts with the operand ``left`` and whose operators bind
        at ``level`` or tighter (:data:`BINARY_PRECEDENCE`; precedence climbing,
        left-associative)."""
        lv = PRECEDENCE.get(self.peek())
        while lv is not None and lv >= level:
            op = self.take()
            right = self.unary()
            nxt = PRECEDENCE.get(self.peek())
            while nxt is not None and nxt > lv:
                right = self.climb(right, lv + 1)
                nxt = PRECEDENCE.get(self.peek())
            left = Binary(op, left, right)
            lv = PRECEDENCE.get(self.peek())
        return left

    def unary(self):
        t = self.peek()
        if t in ("-", "+", "!", "~"):
            self.take()
            return Unary(t, self.unary())
        if t in ("++", "--"):
            self.take()
            return IncDec(t, self.unary(), False)
        return self.postfix()

    def postfix(self):
        e = self.primary()
        while True:
            t = self.peek()
            if t == "[":
                e = Index(e, self.inside("[", "]"))
            elif self.accept("."):
                e = Member(e, self.take())
            elif t in ("++", "--"):
                self.take()
                e = IncDec(t, e, True)
            else:
                return e

    def args(self) -> list:
        self.take("(")
        out = []
        while self.peek() != ")":
            out.append(self.assign_expr())
            self.accept(",")
        self.take(")")
        return out

    def primary(self):
        k, t = self.kind(), self.peek()
        if k == "num":
            self.take()
            return Num(t)
        if t == "(":
            return Paren(self.inside("(", ")"))
        if k == "id":
            self.take()
            if self.peek() == "[" and self.is_type(-1):
                return ArrayCtor(t, self.inside("[", "]"), self.args())
            if self.peek() == "(":
                return (Ctor if self.is_type(-1) else Call)(t, self.args())
            return Name(t)
        raise TranslateError(f"GLSL syntax: unexpected {t!r}")


def parse(text: str, structs=()) -> Unit:
    """The tree of ``text`` (preprocessed GLSL); :class:`TranslateError` names what it cannot
    read. ``structs``: struct types declared elsewhere (``text`` is a part of a module)."""
    p = _Parser(text)
    p.structs.update(structs)
    return p.unit()


@lru_cache(maxsize=64)
def parsed_library(text: str) -> Unit:
    """:func:`parse` of a library text, cached per process (the tree is shared: copy it before
    changing it). Each top-level declaration is parsed once per process: the programs of one
    library share most of their declarations' text (:func:`_declaration`)."""
    split = split_tokens(text)
    structs = frozenset(split[k + 2][1] for k in range(len(split) - 2)
                        if split[k] == ("id", "struct") and split[k + 1][0] == "ws")
    items, chunk, depth, k = [], [], 0, 0
    while k < len(split):
        kind, t = split[k]
        chunk.append(t)
        k += 1
        depth += (t == "{") - (t == "}")
        if depth == 0 and (t == ";" or t == "}" and next(x for c, x in split[k - len(chunk):k]
                                                          if c not in ("ws", "comment")) != "struct"):
            # the rest of the line (a comment after the declaration) goes with it
            while k < len(split) and (split[k][0] == "comment" and split[k][1].startswith("//")
                                      or split[k][0] == "ws" and "\n" not in split[k][1]):
                chunk.append(split[k][1])
                k += 1
            items += _declaration("".join(chunk), structs).items
            chunk = []
    return Unit(items, _declaration("".join(chunk), structs).trailing)


def _declaration(text: str, structs: frozenset) -> Unit:
    # keyed by the struct names ``text`` may mention: the libraries of two presets declare
    # different structs, their shared declarations hit the cache all the same
    return _parsed_declaration(text, frozenset(s for s in structs if s in text))


@lru_cache(maxsize=4096)
def _parsed_declaration(text: str, structs: frozenset) -> Unit:
    return parse(text, structs)
