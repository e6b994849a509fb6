"""Which template families feed which question file, and how many questions each file gets per scene.

The quotas give about 30 questions per rendered scene: occlusion questions need occluded objects, which about half
of the scenes have, so the occlusion files often fall short of their quota.

The released Super-CLEVR-3D question files map to template directories (spec §3.1): ``parts`` = part.json,
``pose`` = pose.json, ``occlusion`` = occlusion.json + occlusion_by.json, ``obj_occlusion`` = the object-level
subset (occlusion 2-5, occlusion_by 1-8). ``core`` (CLEVR-style questions) and ``height_depth`` (elevated
aeroplanes, paper §6) are ours. Family indices are always those of our full template files, so a family has one
identity across question files.

Under public semantics (docs/semantics.md row 24) the ``obj_occlusion`` file numbers its families like the public
``super_clevr_object_occlusion`` copies (occlusion 2-5 -> 0-3, occlusion_by 1-8 -> 0-7): :func:`public_family_index`.
"""

from __future__ import annotations

from dataclasses import dataclass

from po3d_ppl.questions.template_format import load_template_file


@dataclass(frozen=True)
class QuestionSet:
    name: str
    #: (template file, family index) pairs
    families: tuple[tuple[str, int], ...]
    #: questions emitted per scene (at most one per family)
    per_scene: int


def _all(filename: str) -> tuple[tuple[str, int], ...]:
    return tuple((filename, i) for i in range(len(load_template_file(filename))))


#: question set -> template file -> offset of the public renumbering (row 24)
PUBLIC_RENUMBERING = {"obj_occlusion": {"occlusion.json": 2, "occlusion_by.json": 1}}


def public_family_index(question_set: str, filename: str, index: int) -> int:
    """The family index a public question file uses for our family ``filename:index`` in ``question_set``."""
    return index - PUBLIC_RENUMBERING.get(question_set, {}).get(filename, 0)


def question_sets(height_depth: bool = False) -> dict[str, QuestionSet]:
    """The question files of a dataset build, in output order."""
    sets = [
        QuestionSet("parts", _all("parts.json"), 7),
        QuestionSet("pose", _all("pose.json"), 7),
        QuestionSet("occlusion", _all("occlusion.json") + _all("occlusion_by.json"), 8),
        QuestionSet("obj_occlusion", tuple(("occlusion.json", i) for i in range(2, 6))
                    + tuple(("occlusion_by.json", i) for i in range(1, 9)), 4),
        QuestionSet("core", _all("core.json"), 8),
    ]
    if height_depth:
        sets.append(QuestionSet("height_depth", _all("height_depth.json"), 4))
    return {s.name: s for s in sets}
