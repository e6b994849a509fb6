"""Inference on CUDA equals inference on the CPU (skipped without a GPU).

Evidence moved to the GPU (``evidence.to("cuda")``) makes every engine run there; answers must agree with the CPU
run to 1e-9 (exact) and exactly (sampling draws its uniforms on the CPU from the same seed).
"""

from __future__ import annotations

import pytest
import torch

from po3d_ppl.perception import simulated_evidence
from po3d_ppl.reasoning import SceneReasoner
from po3d_ppl.world import generate_scene
from po3d_ppl.world.sampler import SceneConfig

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")

PROGRAMS = [
    "count(filter_color[red](scene()))",
    "query_color(unique(filter_shape[car](scene())))",
    "exist(relate_occluded(unique(filter_shape[bus](scene()))))",
    "count(partfilter_occludee(object2part_all(scene())))",
    "query_pose(unique(filter_size[large](scene())))",
    "equal_integer(count(filter_material[metal](scene())), count(filter_material[rubber](scene())))",
]


@pytest.fixture(scope="module")
def evidences():
    scenes = [generate_scene(seed=s, config=SceneConfig(min_objects=6, max_objects=8)).scene for s in (1, 2)]
    return [simulated_evidence(scene, noise=0.1, seed=k) for k, scene in enumerate(scenes)]


@pytest.mark.parametrize("method", ["exact", "sampling", "thresholded", "soft"])
def test_cuda_answers_equal_cpu_answers(evidences, method):
    for evidence in evidences:
        cpu, gpu = SceneReasoner(evidence), SceneReasoner(evidence.to("cuda"))
        assert gpu.posteriors.probs["exists"].device.type == "cuda"
        for program in PROGRAMS:
            a, b = cpu.infer(program, method, num_samples=1024), gpu.infer(program, method, num_samples=1024)
            assert abs(a.invalid - b.invalid) < 1e-9, (program, method)
            for answer in set(a.probs) | set(b.probs):
                assert abs(a.probs.get(answer, 0.0) - b.probs.get(answer, 0.0)) < 1e-9, (program, method, answer)
