"""Memory and time budgets for one inference call, enforced before anything too large is allocated.

Every inference method runs its tensor code under :func:`enforce`, a ``TorchFunctionMode`` that sees each torch
call before it runs. For element-wise and broadcasting calls (the operations of a program on an enumerated world,
the contractions of the exact engine, Pyro's variable elimination) the result's size is the broadcast of the
inputs' shapes, so the call is refused *before* it allocates when that would exceed the budget; the clock is
checked at every call too. Exceeding either raises a :class:`BudgetExceeded` (typed, one line), which ``auto``
answers by falling back from exact inference to sampling, and which the other methods report as a refusal.

A budget bounds the largest single tensor at half the memory cap (sized by its widest input's element: a
comparison of bool sets costs a byte an element, float64 tables eight), leaving room for the few live tensors an
engine holds at once; the fuzz benchmark (``benchmarks/bench_fuzz_inference.py``) measures the peak resident
memory this gives.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import torch
from torch.overrides import TorchFunctionMode

from po3d_ppl.errors import InputError, Po3dError

#: Bytes per element assumed where a bound has no inputs to size it by (the engines compute in float64).
ELEMENT_BYTES = 8
#: The largest single tensor may take this share of the memory cap.
TENSOR_SHARE = 0.5


@dataclass(frozen=True)
class Budget:
    """Per-call limits: memory in bytes (default 2 GiB) and wall-clock seconds (default 10 s; None: no limit)."""

    max_bytes: int = 2 << 30
    max_seconds: float | None = 10.0

    def __post_init__(self) -> None:
        if not isinstance(self.max_bytes, int) or isinstance(self.max_bytes, bool) or self.max_bytes < 1 << 20:
            raise InputError("budget.max_bytes", f"must be an integer number of bytes >= 1 MiB, got {self.max_bytes!r}")
        if self.max_seconds is not None and not (isinstance(self.max_seconds, (int, float))
                                                 and math.isfinite(self.max_seconds) and self.max_seconds > 0):
            raise InputError("budget.max_seconds", f"must be a positive number of seconds or None, got "
                             f"{self.max_seconds!r}")

    @property
    def max_tensor_bytes(self) -> int:
        """The largest single tensor allowed, in bytes."""
        return int(self.max_bytes * TENSOR_SHARE)

    @property
    def max_elements(self) -> int:
        """The largest single float64 tensor allowed, in elements."""
        return self.max_tensor_bytes // ELEMENT_BYTES


class BudgetExceeded(Po3dError):
    """An inference call would exceed its memory or time budget; nothing that large was allocated."""


class MemoryBudgetExceeded(BudgetExceeded, MemoryError):
    pass


class TimeBudgetExceeded(BudgetExceeded, TimeoutError):
    pass


def _broadcast_numel(shapes) -> int:
    """Elements of the broadcast of ``shapes`` (0 if they do not broadcast); plain Python, as this runs on every
    torch call (``torch.broadcast_shapes`` costs ten times more)."""
    rank = max(len(shape) for shape in shapes)
    total = 1
    for axis in range(1, rank + 1):
        size = 1
        for shape in shapes:
            if axis <= len(shape):
                d = shape[-axis]
                if d != 1:
                    if size != 1 and d != size:
                        return 0
                    size = d
        total *= size
    return total


def _tensors(values) -> list[torch.Tensor]:
    """Tensor arguments, top level and one level into tuples and lists (where torch calls keep them)."""
    out = []
    for value in values:
        if isinstance(value, torch.Tensor):
            out.append(value)
        elif isinstance(value, (tuple, list)):
            out += [v for v in value if isinstance(v, torch.Tensor)]
    return out


def _result_bytes(func, args, kwargs) -> int:
    """The size of a broadcasting call's result from its inputs' shapes, at its widest input's element size (0 when
    the call is not sized that way)."""
    if func is torch.Tensor.__getitem__:  # advanced indexing: the broadcast index shape, then the untouched dims
        source, index = args[0], args[1] if isinstance(args[1], tuple) else (args[1],)
        indices = [i.shape for i in index if isinstance(i, torch.Tensor)]
        if not indices:
            return 0
        return _broadcast_numel(indices) * math.prod(source.shape[len(index):]) * source.element_size()
    tensors = _tensors(args)
    if kwargs:
        tensors += _tensors(kwargs.values())
    if len(tensors) < 2:
        return 0
    # a call whose inputs do not broadcast (einsum, matmul, cat ...) gives 0: torch sizes it from its inputs
    return _broadcast_numel([t.shape for t in tensors]) * max(t.element_size() for t in tensors)


def _check_clock(deadline: float | None, budget: Budget, what: str) -> None:
    if deadline is not None and time.monotonic() > deadline:
        raise TimeBudgetExceeded(f"{what} ran past its {budget.max_seconds:g} s budget; raise budget.max_seconds or "
                                 "use method='sampling'")


def _deadline(budget: Budget) -> float | None:
    return None if budget.max_seconds is None else time.monotonic() + budget.max_seconds


class _Guard(TorchFunctionMode):
    def __init__(self, budget: Budget, what: str, deadline: float | None):
        super().__init__()
        self.budget, self.what, self.deadline = budget, what, deadline

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        size = _result_bytes(func, args, kwargs)
        if size > self.budget.max_tensor_bytes:
            raise MemoryBudgetExceeded(
                f"{self.what} would build a {size / 2**30:.2f} GiB tensor (limit "
                f"{self.budget.max_tensor_bytes / 2**30:.2g} GiB for a {self.budget.max_bytes / 2**30:.2g} GiB "
                "budget): refused before allocating; raise the budget or use method='sampling'")
        _check_clock(self.deadline, self.budget, self.what)
        return func(*args, **kwargs)


class LazyGuard:
    """The guard, entered only once the tensors *could* outgrow the budget.

    The exact engine knows an upper bound on every tensor it builds: the product of all its enumeration dimensions
    with the object and part axes (``grow``). While that bound is under the budget no call can exceed it, so the
    engine pays nothing; past it, the guard checks every call from then on. The clock is checked on ``grow`` and
    ``tick`` (the engine's loops).
    """

    def __init__(self, budget: Budget, what: str):
        self.budget, self.what, self.deadline = budget, what, _deadline(budget)
        self._guard: _Guard | None = None

    def grow(self, bound: int) -> None:
        if bound > self.budget.max_elements and self._guard is None:
            self._guard = _Guard(self.budget, self.what, self.deadline)
            self._guard.__enter__()
        self.tick()

    def tick(self) -> None:
        _check_clock(self.deadline, self.budget, self.what)

    def close(self) -> None:
        if self._guard is not None:
            self._guard.__exit__(None, None, None)
            self._guard = None


def enforce(budget: Budget, what: str = "inference") -> TorchFunctionMode:
    """A context that runs the enclosed torch code within ``budget`` (see the module docstring)."""
    return _Guard(budget, what, _deadline(budget))
