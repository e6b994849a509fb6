"""With certain evidence from ground-truth scenes, every inference method agrees with the reference executor on the
questions of a generated dataset (rendered scenes, all question files; the suite's shared build, subsampled)."""

from __future__ import annotations

import pytest

from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.executor import execute
from po3d_ppl.reasoning import SceneReasoner

#: Every third scene of the shared 200-scene build: about 2,000 questions.
SCENE_STRIDE = 3


@pytest.fixture(scope="module")
def dataset(shared_dataset):
    _, _, data = shared_dataset
    by_image: dict[int, list[dict]] = {}
    for questions in data.questions.values():
        for q in questions:
            if q["image_index"] % SCENE_STRIDE == 0:
                by_image.setdefault(q["image_index"], []).append(q)
    return data, by_image


def _program(question: dict) -> list[dict]:
    return [{k: v for k, v in node.items() if k != "_output"} for node in question["program"]]


@pytest.mark.slow
def test_exact_equals_the_reference_executor_on_every_question(dataset):
    data, by_image = dataset
    checked = 0
    for index, questions in sorted(by_image.items()):
        scene = data.scene(index)
        reasoner = SceneReasoner(simulated_evidence(scene))
        for q in questions:
            program = _program(q)
            reference = execute(scene, program)
            assert reference.valid, q["question"]
            dist = reasoner.infer(program, "exact")
            assert dist.top == reference.answer, (index, q["question"], dist.probs, reference.answer)
            assert dist.probability(reference.answer) == pytest.approx(1.0, abs=1e-9)
            assert dist.invalid == pytest.approx(0.0, abs=1e-9)
            checked += 1
    assert checked >= 2000


def test_baselines_agree_with_the_reference_under_certainty(dataset):
    data, by_image = dataset
    for index in sorted(by_image)[:6]:
        scene = data.scene(index)
        reasoner = SceneReasoner(simulated_evidence(scene))
        for q in by_image[index]:
            answer = execute(scene, _program(q)).answer
            for method in ("thresholded", "soft", "sampling"):
                dist = reasoner.infer(_program(q), method, num_samples=64)
                assert dist.top == answer, (method, q["question"], dist.probs)
