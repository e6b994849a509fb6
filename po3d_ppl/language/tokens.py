"""Programs <-> prefix token sequences (the NS-VQA target format for sequence models).

A program becomes its operations in prefix (pre-order) order, each token ``function`` or ``function[value]``:
``query_color unique filter_shape[car] filter_color[red] scene``. Reading a sequence back needs each operation's
arity, taken from the registry, so every overload of a name must have the same number of inputs and the same value
type (true of the built-ins; :func:`token_signature` reports a registry where it is not).

Prefix sequences describe trees: a node read twice (a binding) is written out twice, and reading the tokens back
gives the expanded tree, which computes the same result. For tree-shaped programs in post-order (all generated
and public programs) ``program_from_tokens(program_to_tokens(p)) == p`` exactly; in general it equals the
canonical, expanded form of ``p``.
"""

from __future__ import annotations

from collections.abc import Sequence

from po3d_ppl.catalogue import OperationRegistry, RegistryError
from po3d_ppl.language.ast import Node, Program
from po3d_ppl.language.errors import ProgramStructureError, UnknownProgramNameError


def format_token(function: str, value: str | None) -> str:
    return function if value is None else f"{function}[{value}]"


def split_token(token: str) -> tuple[str, str | None]:
    """``'filter_shape[car]'`` -> ``('filter_shape', 'car')``; ``'scene'`` -> ``('scene', None)``."""
    if not isinstance(token, str) or not token:
        raise ProgramStructureError(f"a program token must be a non-empty string, got {token!r}")
    if "[" not in token:
        return token, None
    function, _, rest = token.partition("[")
    if not rest.endswith("]"):
        raise ProgramStructureError(f"token {token!r}: a value must be closed with ']' (function[value])")
    return function, rest[:-1]


def token_signature(name: str, registry: OperationRegistry) -> tuple[int, str | None]:
    """(arity, value type) shared by all overloads of ``name``; prefix sequences need them to be unique."""
    overloads = registry.overloads(name)
    shapes = {(len(op.inputs), op.value) for op in overloads}
    if len(shapes) != 1:
        raise RegistryError(f"operation {name!r} has overloads with different arities or value types "
                            f"({sorted(shapes, key=str)}); prefix token sequences cannot represent it")
    return shapes.pop()


def program_to_tokens(program: Program) -> list[str]:
    """Prefix tokens of ``program`` (shared nodes are repeated, see the module docstring)."""
    tokens: list[str] = []
    stack = [program.root]
    while stack:
        node = program[stack.pop()]
        tokens.append(format_token(node.function, node.value))
        stack.extend(reversed(node.inputs))
    return tokens


def program_from_tokens(tokens: Sequence[str] | str, registry: OperationRegistry | None = None) -> Program:
    """Read prefix tokens (a list, or one whitespace-separated string) back into a post-ordered tree program."""
    from po3d_ppl.language.typecheck import default_registry

    registry = registry if registry is not None else default_registry()
    if isinstance(tokens, str):
        tokens = tokens.split()
    if not tokens:
        raise ProgramStructureError("an empty token sequence is not a program")
    # Each pending frame: [function, value, arity, collected input indices].
    nodes: list[Node] = []
    frames: list[list] = []
    for position, token in enumerate(tokens):
        function, value = split_token(token)
        if function not in registry:
            raise UnknownProgramNameError("operation", function, registry.names(),
                                          hint=f"token {position} of the sequence")
        if not frames and nodes:
            raise ProgramStructureError(f"token {position} ({token!r}) follows a complete program")
        arity, _ = token_signature(function, registry)
        frames.append([function, value, arity, []])
        while frames and len(frames[-1][3]) == frames[-1][2]:
            function, value, _, inputs = frames.pop()
            nodes.append(Node(function, tuple(inputs), value))
            if frames:
                frames[-1][3].append(len(nodes) - 1)
    if frames:
        missing = sum(f[2] - len(f[3]) for f in frames)
        raise ProgramStructureError(f"the token sequence ends {missing} input(s) short of a complete program "
                                    f"(unfinished: {', '.join(f[0] for f in frames)})")
    return Program(tuple(nodes))
