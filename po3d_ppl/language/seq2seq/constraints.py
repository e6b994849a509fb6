"""Grammar- and type-constrained decoding: which target tokens may come next in a prefix program.

The decoder writes a program in prefix order. The automaton keeps a stack of pending operations; each frame
holds the overloads still possible for its operation and the types of the inputs completed so far. The next
token must be

- a value of the frame's value type right after an operation that takes one, else
- an operation with an overload whose output type fits the input slot being filled (the union of that slot's
  types over the frame's remaining overloads), and whose cheapest completion still fits in the length budget.

When an operation's last input completes, its overload is known, so its output type narrows its parent's
overloads. The result is that every finished sequence is a program :func:`~po3d_ppl.language.check_program`
accepts, and every sequence can always be finished within ``max_len`` tokens (no dead ends).

Masks depend only on the slot's type set, the finishing costs and the budget, so they are cached (as numpy
arrays: on vectors this small numpy is several times faster than torch, and decoding is latency bound). The same automaton
yields the per-position mask ids used for constrained (masked-softmax) training.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import inf

import numpy as np

from po3d_ppl.catalogue import OperationRegistry, value_vocabulary
from po3d_ppl.language.seq2seq.vocab import TargetVocabulary
from po3d_ppl.language.tokens import token_signature


@dataclass(frozen=True)
class _Overload:
    name: str
    inputs: tuple[str, ...]
    output: str | None  # None for the virtual root
    value: str | None


@dataclass(frozen=True)
class Frame:
    """A pending operation: overloads still possible, completed input types, whether its value is due.

    ``slot`` is the set of types its next input may have; ``finish`` maps each of them to the fewest tokens
    needed, once that input is complete, to finish this operation and every enclosing one.
    """

    candidates: frozenset[int]
    done: tuple[str, ...]
    value_due: bool
    slot: frozenset[str]
    finish: tuple[tuple[str, float], ...]
    #: The slot being filled is the operation's last input.
    closing: bool = False


@dataclass(frozen=True)
class DecodeState:
    """An immutable decoding state (beams share and branch them freely)."""

    stack: tuple[Frame, ...]
    length: int

    @property
    def complete(self) -> bool:
        return not self.stack

    @property
    def closing(self) -> bool:
        """Whether every pending operation is at its last input (so a leaf token would finish the program)."""
        return all(len(f.slot) and f.closing for f in self.stack)


class TypeAutomaton:
    """Allowed-next-token masks and state transitions for one registry and target vocabulary."""

    def __init__(self, registry: OperationRegistry, targets: TargetVocabulary, root_types: tuple[str, ...],
                 max_len: int = 64):
        self.targets, self.max_len = targets, max_len
        self.overloads: list[_Overload] = []
        self.by_token: dict[int, list[int]] = {}
        self.value_type_of: dict[int, str | None] = {}
        for name in targets.operations:
            token = targets.op_id(name)
            if name not in registry:
                continue  # the model knows an operation this registry lacks: never emit it
            _, value_type = token_signature(name, registry)
            self.value_type_of[token] = value_type
            for op in registry.overloads(name):
                self.by_token.setdefault(token, []).append(len(self.overloads))
                self.overloads.append(_Overload(name, op.inputs, op.output, op.value))
        self.root_ids = []
        for t in root_types:
            self.root_ids.append(len(self.overloads))
            self.overloads.append(_Overload("<root>", (t,), None, None))
        self.cost = self._type_costs()
        #: Operation tokens that finish their own node at once (no inputs, no value).
        self.leaf = np.zeros(len(targets), dtype=bool)
        for token, indices in self.by_token.items():
            self.leaf[token] = self.value_type_of[token] is None and all(
                not self.overloads[i].inputs for i in indices)
        self.vocab_size = len(targets)
        self._slot_cache: dict[frozenset[str], tuple[np.ndarray, dict[str, np.ndarray]]] = {}
        self._value_cache: dict[str, np.ndarray] = {}
        self._allowed_cache: dict[tuple, np.ndarray] = {}
        self._frame_cache: dict[tuple, Frame] = {}
        self.mask_keys: list[tuple] = []
        self._mask_key_ids: dict[tuple, int] = {}

    # ----- static tables -------------------------------------------------------------------------------------
    def _type_costs(self) -> dict[str, float]:
        """Fewest tokens that produce a value of each type (fixed point over the signatures)."""
        cost: dict[str, float] = {}
        changed = True
        while changed:
            changed = False
            for ov in self.overloads:
                if ov.output is not None:
                    c = self._overload_cost(ov, cost)
                    if c < cost.get(ov.output, inf):
                        cost[ov.output] = c
                        changed = True
        return cost

    @staticmethod
    def _overload_cost(ov: _Overload, cost: dict[str, float]) -> float:
        return 1 + (ov.value is not None) + sum(cost.get(t, inf) for t in ov.inputs)

    def _slot_tables(self, slot: frozenset[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """For an input slot of these types: the allowed-operation mask and, per output type, each token's
        cheapest cost when it produces that type (inf if it cannot)."""
        cached = self._slot_cache.get(slot)
        if cached is None:
            mask = np.zeros(self.vocab_size, dtype=bool)
            by_output = {t: np.full(self.vocab_size, inf) for t in slot}
            for token, indices in self.by_token.items():
                for i in indices:
                    ov = self.overloads[i]
                    c = self._overload_cost(ov, self.cost)
                    if ov.output in slot and c < inf:
                        mask[token] = True
                        by_output[ov.output][token] = min(by_output[ov.output][token], c)
            cached = self._slot_cache[slot] = (mask, by_output)
        return cached

    def _value_mask(self, value_type: str) -> np.ndarray:
        mask = self._value_cache.get(value_type)
        if mask is None:
            mask = np.zeros(self.vocab_size, dtype=bool)
            for value in value_vocabulary(value_type):
                token = self.targets.value_id(value)
                if token is not None:
                    mask[token] = True
            self._value_cache[value_type] = mask
        return mask

    # ----- states --------------------------------------------------------------------------------------------
    def initial(self) -> DecodeState:
        return DecodeState((self._frame(frozenset(self.root_ids), (), False, ((None, 0.0),)),), 0)

    def _frame(self, candidates: frozenset[int], done: tuple[str, ...], value_due: bool,
               parent_finish: tuple[tuple[str | None, float], ...]) -> Frame:
        """A frame with its slot types and finishing costs, given its parent's finishing costs.

        Finishing this frame after the current slot received type t costs its later inputs plus finishing the
        parent once this frame produced its output; overload choices are correlated through the output types,
        so the minimum is taken per type.
        """
        key = (candidates, done, value_due, parent_finish)
        cached = self._frame_cache.get(key)
        if cached is not None:
            return cached
        parent = dict(parent_finish)
        position = len(done)
        per_type: dict[str, float] = {}
        for i in candidates:
            ov = self.overloads[i]
            if position == len(ov.inputs):
                continue
            c = sum(self.cost.get(t, inf) for t in ov.inputs[position + 1:]) + parent.get(ov.output, inf)
            t = ov.inputs[position]
            if c < per_type.get(t, inf):
                per_type[t] = c
        closing = all(len(self.overloads[i].inputs) == position + 1 for i in candidates)
        frame = self._frame_cache[key] = Frame(candidates, done, value_due, frozenset(per_type),
                                               tuple(sorted(per_type.items())), closing)
        return frame

    def mask_key(self, state: DecodeState) -> tuple:
        """What the allowed set depends on (besides the budget): a value type, or an input slot's types."""
        frame = state.stack[-1]
        if frame.value_due:
            return ("value", self.overloads[next(iter(frame.candidates))].value)
        return ("slot", frame.slot)

    def mask_key_id(self, state: DecodeState) -> int:
        """A small integer per distinct mask key (training stores these instead of masks)."""
        key = self.mask_key(state)
        index = self._mask_key_ids.get(key)
        if index is None:
            index = self._mask_key_ids[key] = len(self.mask_keys)
            self.mask_keys.append(key)
        return index

    def key_mask(self, key: tuple) -> np.ndarray:
        return self._value_mask(key[1]) if key[0] == "value" else self._slot_tables(key[1])[0]

    def mask_table(self) -> np.ndarray:
        """``[num_keys, vocab]`` masks of every key seen by :meth:`mask_key_id` (no length budget)."""
        return np.stack([self.key_mask(k) for k in self.mask_keys])

    def allowed(self, state: DecodeState) -> np.ndarray:
        """Boolean mask over the target vocabulary of the tokens that may come next (do not modify it)."""
        frame = state.stack[-1]
        if frame.value_due:
            return self._value_mask(self.overloads[next(iter(frame.candidates))].value)
        budget = self.max_len - state.length
        cache_key = (frame.finish, budget)
        mask = self._allowed_cache.get(cache_key)
        if mask is None:
            base, by_output = self._slot_tables(frame.slot)
            fits = np.zeros_like(base)
            for t, rest in frame.finish:
                fits |= (by_output[t] + rest) <= budget
            mask = self._allowed_cache[cache_key] = base & fits
        return mask

    def completes(self, state: DecodeState, token: int) -> bool:
        """Whether emitting the allowed ``token`` finishes the program (cheaper than :meth:`advance`)."""
        top = state.stack[-1]
        if top.value_due:  # the value finishes the program only if its operation has no inputs
            return not top.slot and DecodeState(state.stack[:-1], 0).closing
        return self.leaf[token] and state.closing

    def advance(self, state: DecodeState, token: int) -> DecodeState:
        """The state after emitting ``token`` (which must be allowed)."""
        stack = list(state.stack)
        top = stack[-1]
        if top.value_due:
            stack[-1] = Frame(top.candidates, top.done, False, top.slot, top.finish, top.closing)
        else:
            candidates = frozenset(i for i in self.by_token.get(token, ()) if self.overloads[i].output in top.slot)
            if not candidates:
                raise ValueError(f"token {self.targets.tokens[token]!r} is not allowed here")
            stack.append(self._frame(candidates, (), self.value_type_of[token] is not None, top.finish))
        self._pop_finished(stack)
        return DecodeState(tuple(stack), state.length + 1)

    def _pop_finished(self, stack: list[Frame]) -> None:
        """Pop finished frames, narrowing each parent's overloads with the child's output type."""
        while stack:
            top = stack[-1]
            if top.value_due or top.slot:
                return
            (index,) = top.candidates
            stack.pop()
            if stack:
                produced = self.overloads[index].output
                parent = stack[-1]
                position = len(parent.done)
                narrowed = frozenset(i for i in parent.candidates
                                     if self.overloads[i].inputs[position] == produced)
                grand = stack[-2].finish if len(stack) > 1 else ((None, 0.0),)
                stack[-1] = self._frame(narrowed, (*parent.done, produced), False, grand)
