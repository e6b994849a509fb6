"""Fixtures shared by several test modules."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def torch_one_thread():
    """torch on one CPU thread for the module's tests, restored afterwards. The models under test are small: one
    thread is faster, and immune to oversubscription when the suite runs in parallel."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture
def builtin_registry_copy():
    """A fresh operation registry holding the built-in operations, for a test to register its own operations in
    without touching the process-wide registry."""
    from po3d_ppl.catalogue import OperationRegistry
    from po3d_ppl.language.typecheck import default_registry

    registry = OperationRegistry()
    for op in default_registry():
        registry.register(op)
    return registry
