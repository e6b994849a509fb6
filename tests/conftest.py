"""Fixtures shared by several test modules."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session", autouse=True)
def torch_single_thread_session():
    """The whole suite runs torch on one thread: its tensors are small, and on a 2-core machine with another busy
    process OpenMP's spinning threads make two threads ten times slower than one (measured: 69 s against 7 s for
    the sampling-families test while a training job ran)."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


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


#: The one rendered dataset the suite builds (200 scenes, 320x240, elevated aeroplanes so every family can occur),
#: shared by the dataset tests and the certain-evidence reasoning test.
SHARED_DATASET = dict(scenes=200, seed=2024, width=320, height=240, height_depth=True)


@pytest.fixture(scope="session")
def shared_dataset(tmp_path_factory):
    """(root, build report, loaded dataset) of :data:`SHARED_DATASET`, built once per test session."""
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset, load_dataset

    root = tmp_path_factory.mktemp("shared_dataset")
    report = build_dataset(root, BuildConfig(**SHARED_DATASET), workers=2)
    return root, report, load_dataset(root)


@pytest.fixture(scope="session")
def tiny_eval_dataset(tmp_path_factory):
    """A loaded six-scene dataset at 160x120 (seed 77): the evaluation tests' questions and scenes."""
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset, load_dataset

    root = tmp_path_factory.mktemp("eval_data")
    build_dataset(root, BuildConfig(scenes=6, seed=77, width=160, height=120), workers=1)
    return load_dataset(root)
