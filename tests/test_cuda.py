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


def test_the_shipped_parser_ensemble_parses_on_cuda_as_on_the_cpu():
    from po3d_ppl.language import load_question_parser

    question = "Are there more cars right of the blue bus than left of it?"
    cpu, gpu = load_question_parser(), load_question_parser(device="cuda")
    a, b = cpu.parse(question, n=3), gpu.parse(question, n=3)
    assert [c.tokens for c in a.candidates] == [c.tokens for c in b.candidates]
    assert [c.log_prob for c in a.candidates] == pytest.approx([c.log_prob for c in b.candidates], abs=1e-4)
