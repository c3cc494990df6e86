"""A straight-line program recorded by running numeric code on tracer values.

The Newton–Euler regressor is run once on ``Sym`` values instead of floats.  A
value is either a Python float (a constant of the robot: its geometry, folded at
once) or a ``Sym``, a node of the program being recorded.  Folding keeps the
program small without any symbolic algebra:

    0·x → 0,  1·x → x,  −1·x → −x,  0 + x → x,  x − 0 → x,  c ⊕ c' → (c ⊕ c'),
    x + (−y) → x − y,  −(−x) → x,

and equal operations on equal operands are recorded once (hash-consing, which is
common-subexpression elimination for free).  Every rewrite is exact in IEEE
arithmetic (a negation or a multiplication by ±1 never rounds), so the program
computes what the recorded code computes, up to the order of additions that the
recorded code itself fixes.

The program is then written out by one emitter per language (``emit_*.py``);
``Program.counts`` gives the operation counts the papers compare (Khalil &
Kleinfinger 1987 count multiplications and additions of the customised
Newton–Euler model).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

# unary functions a program may call; each emitter maps them to its language
FUNCTIONS = ("sin", "cos", "tanh", "exp", "abs", "sign", "pos", "negind")
# pos(x) = 1 if x > 0 else 0;  negind(x) = 1 if x < 0 else 0  (the asymmetric Coulomb indicators)


class Sym:
    """A value computed by the program: node ``i`` of ``prog``.  Arithmetic with floats and other
    Syms records new nodes (folding constants where it can)."""

    __slots__ = ("prog", "i")

    def __init__(self, prog: "Program", i: int):
        self.prog = prog
        self.i = i

    def __add__(self, other):
        return self.prog.add(self, other)

    def __radd__(self, other):
        return self.prog.add(other, self)

    def __sub__(self, other):
        return self.prog.sub(self, other)

    def __rsub__(self, other):
        return self.prog.sub(other, self)

    def __mul__(self, other):
        return self.prog.mul(self, other)

    def __rmul__(self, other):
        return self.prog.mul(other, self)

    def __neg__(self):
        return self.prog.neg(self)

    def __repr__(self) -> str:
        return f"t{self.i}"


@dataclass(frozen=True)
class Node:
    """One instruction: ``op`` over ``args`` (node indices as int, constants as float, input
    references as ("in", name, index))."""

    op: str
    args: tuple


class Program:
    """The instructions recorded so far; ``inputs`` are named vectors (q, qd, qdd, ...)."""

    def __init__(self):
        self.nodes: list[Node] = []
        self._memo: dict = {}
        self.inputs: dict[str, int] = {}

    # --- recording -------------------------------------------------------------------------------

    def input(self, name: str, size: int) -> list[Sym]:
        self.inputs[name] = size
        return [self._node("in", (name, k)) for k in range(size)]

    def _node(self, op: str, args: tuple) -> Sym:
        key = (op, tuple((type(a) is float, a) for a in args))
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        self.nodes.append(Node(op, args))
        s = Sym(self, len(self.nodes) - 1)
        self._memo[key] = s
        return s

    @staticmethod
    def _arg(x):
        return x.i if isinstance(x, Sym) else float(x)

    def _is_neg(self, x) -> bool:
        return isinstance(x, Sym) and self.nodes[x.i].op == "neg"

    def _neg_arg(self, x: Sym) -> Sym:
        return Sym(self, self.nodes[x.i].args[0])

    def add(self, a, b):
        if not isinstance(a, Sym) and not isinstance(b, Sym):
            return float(a) + float(b)
        if not isinstance(a, Sym) and a == 0.0:
            return b
        if not isinstance(b, Sym) and b == 0.0:
            return a
        if self._is_neg(b):
            return self.sub(a, self._neg_arg(b))
        if self._is_neg(a):
            return self.sub(b, self._neg_arg(a))
        x, y = self._arg(a), self._arg(b)
        if _order(y) < _order(x):
            x, y = y, x
        return self._node("add", (x, y))

    def sub(self, a, b):
        if not isinstance(a, Sym) and not isinstance(b, Sym):
            return float(a) - float(b)
        if not isinstance(b, Sym) and b == 0.0:
            return a
        if not isinstance(a, Sym) and a == 0.0:
            return self.neg(b)
        if self._is_neg(b):
            return self.add(a, self._neg_arg(b))
        if self._is_neg(a):  # (−x) − y = −(x + y)
            return self.neg(self.add(self._neg_arg(a), b))
        if isinstance(a, Sym) and isinstance(b, Sym) and a.i == b.i:
            return 0.0
        return self._node("sub", (self._arg(a), self._arg(b)))

    def mul(self, a, b):
        if not isinstance(a, Sym) and not isinstance(b, Sym):
            return float(a) * float(b)
        if not isinstance(a, Sym):
            a, b = b, a  # the constant second
        if not isinstance(b, Sym):
            c = float(b)
            if c == 0.0:
                return 0.0
            if c == 1.0:
                return a
            if c == -1.0:
                return self.neg(a)
            if self._is_neg(a):
                return self.mul(self._neg_arg(a), -c)
            return self._node("mul", (a.i, c))
        neg = False
        if self._is_neg(a):
            a, neg = self._neg_arg(a), not neg
        if self._is_neg(b):
            b, neg = self._neg_arg(b), not neg
        x, y = a.i, b.i
        if y < x:
            x, y = y, x
        out = self._node("mul", (x, y))
        return self.neg(out) if neg else out

    def neg(self, a):
        if not isinstance(a, Sym):
            return -float(a)
        if self._is_neg(a):
            return self._neg_arg(a)
        return self._node("neg", (a.i,))

    def call(self, fn: str, a):
        """fn(a) for one of FUNCTIONS; a constant argument is evaluated now."""
        if fn not in FUNCTIONS:
            raise ValueError(f"unknown function {fn!r}")
        if not isinstance(a, Sym):
            import math

            x = float(a)
            now: dict[str, Callable[[float], float]] = {
                "sin": math.sin, "cos": math.cos, "tanh": math.tanh, "exp": math.exp, "abs": abs,
                "sign": lambda v: float((v > 0) - (v < 0)), "pos": lambda v: float(v > 0),
                "negind": lambda v: float(v < 0)}
            return now[fn](x)
        return self._node(fn, (a.i,))

    # --- reading -------------------------------------------------------------------------------

    def live(self, outputs) -> list[int]:
        """Indices of the nodes the outputs need, in program order (dead code dropped)."""
        need = set()
        stack = [o.i for o in outputs if isinstance(o, Sym)]
        while stack:
            i = stack.pop()
            if i in need:
                continue
            need.add(i)
            node = self.nodes[i]
            if node.op != "in":
                stack.extend(a for a in node.args if type(a) is int)
        return sorted(need)

    def counts(self, outputs) -> dict[str, int]:
        """Operation counts of the live program: multiplications, additions (subtractions
        included), negations and calls of each function."""
        out = {"mul": 0, "add": 0, "neg": 0}
        for i in self.live(outputs):
            op = self.nodes[i].op
            if op == "mul":
                out["mul"] += 1
            elif op in ("add", "sub"):
                out["add"] += 1
            elif op == "neg":
                out["neg"] += 1
            elif op != "in":
                out[op] = out.get(op, 0) + 1
        return out


def _order(x) -> tuple:
    """Sort key putting node indices before constants (canonical operand order for add)."""
    return (1, x) if type(x) is float else (0, x)


def evaluate(prog: Program, outputs, inputs: dict, np):
    """The outputs evaluated on arrays (the test of every emitter: the program itself, run by
    numpy); ``inputs`` maps each input name to a (N, size) array."""
    vals: dict[int, object] = {}
    fns = {"sin": np.sin, "cos": np.cos, "tanh": np.tanh, "exp": np.exp, "abs": np.abs, "sign": np.sign,
           "pos": lambda v: (v > 0).astype(float), "negind": lambda v: (v < 0).astype(float)}

    def get(a):
        return vals[a] if type(a) is int else a

    for i in prog.live(outputs):
        node = prog.nodes[i]
        if node.op == "in":
            name, k = node.args
            vals[i] = inputs[name][:, k]
        elif node.op == "add":
            vals[i] = get(node.args[0]) + get(node.args[1])
        elif node.op == "sub":
            vals[i] = get(node.args[0]) - get(node.args[1])
        elif node.op == "mul":
            vals[i] = get(node.args[0]) * get(node.args[1])
        elif node.op == "neg":
            vals[i] = -get(node.args[0])
        else:
            vals[i] = fns[node.op](get(node.args[0]))
    return [vals[o.i] if isinstance(o, Sym) else o for o in outputs]


def schedule(prog: Program, outputs) -> tuple[list[tuple[int, Node]], dict[int, int]]:
    """The live instructions other than inputs, in order, and each one's local number (t0, t1, ...)."""
    order = [(i, prog.nodes[i]) for i in prog.live(outputs) if prog.nodes[i].op != "in"]
    return order, {i: k for k, (i, _) in enumerate(order)}


BINARY = {"add": "{} + {}", "sub": "{} - {}", "mul": "{} * {}"}


def expressions(prog, outputs, calls: dict[str, str], constant, input_ref) -> tuple[list[tuple[int, str]], list[str]]:
    """The scheduled program as text, for every emitter: [(local index k of t<k>, expression)] in
    order, and each output's expression.  ``calls``: the language's unary functions ("sin" ->
    "sin({})"); ``constant(x)``: a literal; ``input_ref(name, k)``: element k of input ``name``."""
    order, local = schedule(prog, outputs)

    def ref(a) -> str:
        if type(a) is float:
            return constant(a)
        node = prog.nodes[a]
        if node.op == "in":
            return input_ref(node.args[0], node.args[1])
        return f"t{local[a]}"

    assigns = []
    for i, node in order:
        if node.op in BINARY:
            expr = BINARY[node.op].format(ref(node.args[0]), ref(node.args[1]))
        elif node.op == "neg":
            expr = f"-{ref(node.args[0])}"
        else:
            expr = calls[node.op].format(ref(node.args[0]))
        assigns.append((local[i], expr))
    return assigns, [ref(o.i) if isinstance(o, Sym) else constant(o) for o in outputs]
