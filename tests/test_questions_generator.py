"""Question generator on hand-built and random toy scenes: well-posed, constraint-respecting, minimal, balanced."""

from __future__ import annotations

from collections import Counter

import pytest

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.questions.balance import AnswerBalancer
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.generator import Candidate, SceneQuestionGenerator
from po3d_ppl.questions.question_sets import question_sets
from po3d_ppl.questions.reference import InvalidStep
from po3d_ppl.questions.scene_questions import generate_questions
from po3d_ppl.questions.template_format import load_template_file, template_files
from po3d_ppl.questions.toy_scenes import random_toy_scene, toy_object, toy_scene

ALL_FAMILIES = [(f, t.index) for f in template_files() for t in load_template_file(f)]
FILTERS = ("filter_pose", "filter_size", "filter_color", "filter_material", "filter_shape", "partfilter_size",
           "partfilter_color", "partfilter_material", "partfilter_partname")


@pytest.fixture(scope="module")
def generated():
    """Candidates of every family over 25 random scenes (elevated aeroplanes in half of them)."""
    out = []
    for seed in range(25):
        scene = random_toy_scene(seed, elevate_aeroplanes=seed % 2 == 0)
        gen = SceneQuestionGenerator(scene, seed)
        for family in ALL_FAMILIES:
            out.extend((scene, c) for c in gen.candidates(*family))
    return out


def _run_nodes(scene, program):
    return execute(scene, [{k: v for k, v in n.items() if k != "_output"} for n in program])


def test_every_candidate_reexecutes_to_its_outputs(generated):
    assert len(generated) > 2000
    for scene, cand in generated:
        res = _run_nodes(scene, cand.program)
        assert res.valid, (cand.question, res.reason)
        assert res.public_outputs() == [n["_output"] for n in cand.program], cand.question


def test_every_unique_referent_has_one_member(generated):
    for scene, cand in generated:
        for node in cand.program:
            if node["type"] == "unique":
                assert len(cand.program[node["inputs"][0]]["_output"]) == 1


def test_every_family_is_instantiated(generated):
    seen = {(c.template_filename, c.question_family_index) for _, c in generated}
    assert seen == set(ALL_FAMILIES)


def test_candidates_of_a_family_have_distinct_answers(generated):
    per_scene: dict = {}
    for scene, cand in generated:
        per_scene.setdefault((id(scene), cand.template_filename, cand.question_family_index), []).append(
            repr(cand.raw_answer))
    assert all(len(v) == len(set(v)) for v in per_scene.values())


def _filter_runs(program):
    """Maximal runs of filter nodes: (source index, [node indices])."""
    runs, k = [], 0
    while k < len(program):
        if program[k]["type"] in FILTERS:
            start = k
            while k + 1 < len(program) and program[k + 1]["type"] in FILTERS and program[k + 1]["inputs"] == [k]:
                k += 1
            runs.append((program[start]["inputs"][0], list(range(start, k + 1))))
        k += 1
    return runs


def test_descriptions_are_minimal(generated):
    """With redundancy 1, dropping any filter of a multi-filter description changes what it selects."""
    checked = 0
    for scene, cand in generated:
        prog = cand.program
        ctx = None
        for source, run in _filter_runs(prog):
            if len(run) < 2:
                continue
            from po3d_ppl.questions.context import SceneContext

            ctx = ctx or SceneContext(scene)
            full = prog[run[-1]]["_output"]
            for drop in run:
                members = prog[source]["_output"]
                kind = "PartSet" if prog[run[0]]["type"].startswith("part") else "ObjectSet"
                value = frozenset(tuple(int(x) for x in m.split("_")) for m in members) if kind == "PartSet" \
                    else frozenset(members)
                for k in run:
                    if k != drop:
                        op = REGISTRY.resolve(prog[k]["type"], (kind,))
                        value = op.reference_fn(ctx, value, prog[k]["value_inputs"][0])
                assert len(value) != len(full), (cand.question, prog[drop])
                checked += 1
    assert checked > 100


def _functions(cand: Candidate) -> list[str]:
    return [n["type"] for n in cand.program]


def test_constraints_are_respected(generated):
    for _, cand in generated:
        fams = (cand.template_filename, cand.question_family_index)
        fns = _functions(cand)
        if fams[0] == "pose.json" and fams[1] in range(1, 5):
            assert "filter_pose" in fns  # NOT-NULL <R>
        if fams[0] == "pose.json" and (fams[1] == 0 or fams[1] >= 5):
            assert "filter_pose" not in fns  # NULL <R>, <R2>
        if fams == ("parts.json", 0):
            assert "partfilter_color" not in fns and "partfilter_size" not in fns
        if fams[0] == "parts.json" and fams[1] in (6, 7, 8):
            uniques = [n["_output"] for n in cand.program if n["type"] == "unique"]
            assert len(uniques) == 2 and uniques[0] != uniques[1]  # OUT_NEQ
        if fams[0] == "occlusion_by.json":
            rel = max(k for k, f in enumerate(fns) if f.startswith("relate_"))
            # NOT_ALL_NULL on the reference object: it is described by at least one filter
            assert any(f.startswith("filter_") and f != "filter_occludee" for f in fns[:rel])
        if fams[0] == "occlusion.json" and fams[1] in (13, 14, 15):
            occluded = next(n["_output"] for k, n in enumerate(cand.program)
                            if fns[k] == "partfilter_partname")
            assert cand.program[-2]["_output"] not in occluded  # OUT_NEQ between a set and a member


def test_generated_programs_use_one_spelling_per_part_name(generated):
    """Part-name values are canonical (one raw spelling per wording), yet select parts of either spelling."""
    values, other_spelling = Counter(), 0
    for _, cand in generated:
        for node in cand.program:
            if node["type"] == "partfilter_partname":
                value = node["value_inputs"][0]
                assert ontology.canonical_part_name(value) == value, (cand.question, value)
                values[value] += 1
    ambiguous = {ontology.canonical_part_name(n) for n in ontology.RAW_PART_NAMES
                 if ontology.canonical_part_name(n) != n}
    assert values.keys() & ambiguous  # the canonical spelling of a name with two spellings is used
    # and it denotes parts spelled the other way (buses' wheel_back_left for back_left_wheel ...)
    for scene, cand in generated:
        for k, node in enumerate(cand.program):
            if node["type"] == "partfilter_partname" and node["value_inputs"][0] in ambiguous:
                for member in node["_output"]:
                    obj, part = (int(x) for x in member.split("_"))
                    other_spelling += ontology.PARTS[scene.objects[obj].subtype][part] != node["value_inputs"][0]
    assert other_spelling > 0


def test_a_bus_part_is_asked_about_in_the_canonical_spelling():
    scene = toy_scene([toy_object("school", "red", parts={"wheel_back_left": ("blue", "metal")}),
                       toy_object("sedan", "green", position=(2, 0, 0))])
    questions = [c for seed in range(10) for c in SceneQuestionGenerator(scene, seed).candidates("parts.json", 0)]
    named = [c for c in questions if any(n["value_inputs"] == ["back_left_wheel"] for n in c.program)]
    assert named, [c.question for c in questions]
    for cand in named:
        assert "back left wheel" in cand.question
        assert all(n["value_inputs"] != ["wheel_back_left"] for n in cand.program)
        assert _run_nodes(scene, cand.program).valid


def test_height_depth_questions_use_vertical_relations(generated):
    relations = Counter(n["value_inputs"][0] for _, c in generated if c.template_filename == "height_depth.json"
                        for n in c.program if n["type"] == "relate")
    assert set(relations) == {"above", "below", "closer", "farther"}


def test_generation_is_deterministic():
    scene = random_toy_scene(5)
    a = [SceneQuestionGenerator(scene, 11).candidates(*f) for f in ALL_FAMILIES]
    b = [SceneQuestionGenerator(scene, 11).candidates(*f) for f in ALL_FAMILIES]
    c = [SceneQuestionGenerator(scene, 12).candidates(*f) for f in ALL_FAMILIES]
    assert a == b and a != c
    # a family's stream does not depend on which other families ran before it
    gen = SceneQuestionGenerator(scene, 11)
    assert gen.candidates("occlusion.json", 3) == a[ALL_FAMILIES.index(("occlusion.json", 3))]


def test_negative_redundancy_adds_filters_also_to_parts():
    scenes = [random_toy_scene(s) for s in range(6)]
    extra = Counter()
    for scene in scenes:
        for family in [("parts.json", 0), ("parts.json", 7), ("core.json", 3)]:
            minimal = SceneQuestionGenerator(scene, 1, redundancy=1.0).candidates(*family)
            padded = SceneQuestionGenerator(scene, 1, redundancy=-1.0).candidates(*family)
            for cand in padded:
                assert _run_nodes(scene, cand.program).valid
            extra[family] += sum(len(c.program) for c in padded) - sum(len(c.program) for c in minimal)
    assert all(v > 0 for v in extra.values()), extra


def test_redundancy_zero_allows_non_minimal_descriptions():
    scene = toy_scene([toy_object("suv", "red"), toy_object("jet", "blue"), toy_object("sedan", "green")])
    lengths = set()
    for seed in range(40):
        for cand in SceneQuestionGenerator(scene, seed, redundancy=0.0).candidates("core.json", 5):
            lengths.add(sum(n["type"].startswith("filter_") for n in cand.program))
        for cand in SceneQuestionGenerator(scene, seed, redundancy=1.0).candidates("core.json", 5):
            assert sum(n["type"].startswith("filter_") for n in cand.program) == 1
    assert max(lengths) >= 2
    with pytest.raises(ValueError):
        SceneQuestionGenerator(scene, 0, redundancy=2.0)


def test_relational_steps_are_needed():
    """After same_pose, a description that alone picks its referent in the whole scene is not used: "the blue
    thing facing the same way as the suv" would not need the pose. "green" (two in the scene) is fine."""
    scene = toy_scene([toy_object("suv", "red", pose_degree=0), toy_object("jet", "blue", pose_degree=10),
                       toy_object("sedan", "green", pose_degree=5), toy_object("truck", "green", pose_degree=190)])
    answers = set()
    for seed in range(20):
        for cand in SceneQuestionGenerator(scene, seed).candidates("pose.json", 8):
            after = _functions(cand)[_functions(cand).index("same_pose") + 1:]
            assert after[0] == "filter_color" and cand.program[-3]["value_inputs"] == ["green"], cand.question
            answers.add(cand.answer)
    assert answers == {"sedan"}


def test_balancer_rules():
    b = AnswerBalancer()
    fam = ("s", "core.json", 3)  # Color answers

    def cand(answer, answer_type="Color"):
        return Candidate("core.json", 3, "q", ({"_output": answer},), answer, answer_type)

    assert b.accepts(fam, cand("red"))
    b.record(fam, cand("red"))
    assert not b.accepts(fam, cand("red"))
    b.record(fam, cand("blue"))
    assert not b.accepts(fam, cand("red"))  # would hold 2 of 3
    assert b.accepts(fam, cand("green"))
    b.record(fam, cand("green"))
    assert b.accepts(fam, cand("red"))  # 2 of 4
    two = ("s", "core.json", 2)  # Size answers: only the lead rule
    b.record(two, cand("large", "Size"))
    b.record(two, cand("small", "Size"))
    assert b.accepts(two, cand("large", "Size"))
    b.record(two, cand("large", "Size"))
    assert not b.accepts(two, cand("large", "Size"))


def test_generate_questions_public_records():
    balancer = AnswerBalancer()
    total = Counter()
    for seed in range(10):
        scene = random_toy_scene(100 + seed)
        out = generate_questions(scene, seed, balancer=balancer)
        assert set(out) == set(question_sets())
        for name, questions in out.items():
            assert len(questions) <= question_sets()[name].per_scene
            assert len({(q["template_filename"], q["question_family_index"]) for q in questions}) == len(questions)
            for k, q in enumerate(questions):
                assert set(q) == {"image_index", "image_filename", "split", "question", "program", "answer",
                                  "template_filename", "question_family_index", "question_index"}
                assert q["question_index"] == k and q["image_index"] == scene.image_index
                res = _run_nodes(scene, q["program"])
                assert res.public_outputs()[-1] == q["program"][-1]["_output"]
            total[name] += len(questions)
    assert sum(total.values()) >= 10 * 25


def test_invalid_steps_prune_instead_of_failing():
    """A scene where every pose is in a dead zone has no query_pose question, and no error."""
    scene = toy_scene([toy_object("suv", "red", pose_degree=45), toy_object("jet", "blue", pose_degree=135)])
    assert SceneQuestionGenerator(scene, 0).candidates("pose.json", 0) == []
    with pytest.raises(InvalidStep):
        from po3d_ppl.questions.context import SceneContext

        REGISTRY.resolve("query_pose", ("Object",)).reference_fn(SceneContext(scene), 0)
