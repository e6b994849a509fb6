"""Questions for one scene: candidates of every family, balanced selection, public question records."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping
from functools import cache

import numpy as np

from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS, PUBLIC, check_semantics
from po3d_ppl.questions.balance import AnswerBalancer, BalanceKey, FamilyKey, answer_key
from po3d_ppl.questions.generator import Candidate, SceneQuestionGenerator
from po3d_ppl.questions.public import public_rejects
from po3d_ppl.questions.question_sets import QuestionSet, question_sets
from po3d_ppl.questions.template_format import load_template_file
from po3d_ppl.world.scene import Scene


@cache
def has_raw_relate(filename: str, index: int) -> bool:
    """Whether a template has a plain ``relate`` node (the only ones the public answer rejection applies to)."""
    return any(node["type"] == "relate" for node in load_template_file(filename)[index].nodes)


class PublicAnswerBalancer(AnswerBalancer):
    """The public generator's answer rejection (docs/semantics.md row 23): an answer is skipped when it would
    lead the runner-up by more than 1.1 x or exceed 5 x max(median, 5), and only in families with a raw
    ``relate``; every other family takes whatever comes."""

    def accepts(self, family: BalanceKey, candidate: Candidate) -> bool:
        if not has_raw_relate(family[1], family[2]):
            return True
        return not public_rejects(self.answers.get(family, Counter()), answer_key(candidate))


def balancer_for(semantics: str = DEFAULT_SEMANTICS) -> AnswerBalancer:
    return PublicAnswerBalancer() if check_semantics(semantics) == PUBLIC else AnswerBalancer()


def families_of(sets: Iterable[QuestionSet]) -> list[FamilyKey]:
    """Every family used by the sets, once, in a stable order."""
    return sorted({f for s in sets for f in s.families})


def scene_candidates(scene: Scene, seed: int, families: Iterable[FamilyKey], *, redundancy: float = 1.0,
                     max_candidates: int = 3, semantics: str = DEFAULT_SEMANTICS) -> dict[FamilyKey, list[Candidate]]:
    """Candidates (distinct answers) of each family over the scene; families with none are left out."""
    gen = SceneQuestionGenerator(scene, seed, redundancy=redundancy, max_candidates=max_candidates,
                                 semantics=semantics)
    out = {}
    for family in families:
        found = gen.candidates(*family)
        if found:
            out[family] = found
    return out


def public_question(candidate: Candidate, image_index: int, image_filename: str, split: str,
                    question_index: int) -> dict:
    """The public question record (spec §3, CLEVR layout)."""
    return {"image_index": image_index, "image_filename": image_filename, "split": split,
            **candidate.to_public(), "question_index": question_index}


def select_for_scene(candidates: Mapping[FamilyKey, list[Candidate]], sets: Iterable[QuestionSet],
                     balancer: AnswerBalancer, rng: np.random.Generator) -> dict[str, list[Candidate]]:
    """The balanced choice of candidates for every question set (updates ``balancer``)."""
    return {s.name: balancer.select(s.name, list(s.families), candidates, s.per_scene, rng) for s in sets}


def generate_questions(scene: Scene, seed: int = 0, *, sets: Mapping[str, QuestionSet] | None = None,
                       balancer: AnswerBalancer | None = None, redundancy: float = 1.0,
                       split: str | None = None, semantics: str = DEFAULT_SEMANTICS) -> dict[str, list[dict]]:
    """Public question records for one scene, per question set (``question_index`` counts within the call).

    Pass the same ``balancer`` across calls to balance answers over many scenes.
    """
    sets = sets or question_sets()
    balancer = balancer or balancer_for(semantics)
    candidates = scene_candidates(scene, seed, families_of(sets.values()), redundancy=redundancy,
                                  semantics=semantics)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))
    chosen = select_for_scene(candidates, sets.values(), balancer, rng)
    split = scene.split if split is None else split
    return {name: [public_question(c, scene.image_index, scene.image_filename, split, k)
                   for k, c in enumerate(cands)]
            for name, cands in chosen.items()}
