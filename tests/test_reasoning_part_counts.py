"""The recolouring rule as part-state evidence: exact marginals (checked by enumeration), what the rule does to
ambiguous readings, and that without it the factor is the independent one."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import NUM_STYLES, ScenePriors, style_index
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.reasoning.part_counts import independent_part_loglik, part_state_loglik

RULE = ScenePriors(part_visible=0.55, part_recoloured=0.33, max_recoloured_parts=3, recoloured_unlike_body=True)
SUBTYPE = ontology.SUBTYPES.index("tandem")  # the fewest parts (6): small enough to enumerate


@pytest.fixture(scope="module")
def evidence():
    from po3d_ppl.world import SceneConfig, generate_scene

    scene = generate_scene(7, SceneConfig(width=320, height=240, min_objects=3, max_objects=3)).scene
    return simulated_evidence(scene, noise=0.3, seed=1)


def _with_tables(evidence, visible: torch.Tensor, styles: torch.Tensor, colour: torch.Tensor):
    """``evidence`` with object 0's tandem slots set to the given part tables and its colour table."""
    v, s, c = (evidence.part_visible_logodds.clone(), evidence.part_style_loglik.clone(),
               evidence.color_loglik.clone())
    parts = visible.shape[0]
    v[0, SUBTYPE, :parts] = visible
    s[0, SUBTYPE, :parts] = styles
    c[0] = colour
    return dataclasses.replace(evidence, part_visible_logodds=v, part_style_loglik=s, color_loglik=c)


def _posterior(evidence, priors: ScenePriors) -> torch.Tensor:
    joint = part_state_loglik(evidence, priors) + torch.log(priors.part_state_probs())
    return torch.softmax(joint, -1)[0, SUBTYPE]


def test_marginals_match_enumerating_every_recolouring(evidence):
    generator = torch.Generator().manual_seed(3)
    parts = len(ontology.PARTS["tandem"])
    visible = torch.randn(parts, generator=generator, dtype=torch.float64) * 2
    styles = torch.randn(parts, NUM_STYLES, generator=generator, dtype=torch.float64) * 2
    colour = torch.randn(len(ontology.COLORS), generator=generator, dtype=torch.float64)
    ev = _with_tables(evidence, visible, styles, colour)
    got = _posterior(ev, RULE)[:parts]

    # brute force: every (hidden, plain, recoloured) assignment that keeps the rule, looks summed per part
    body = torch.softmax(colour, -1)
    look_colour = torch.arange(NUM_STYLES - 1) // len(ontology.MATERIALS)
    look_prior = (1 - body[look_colour]) / ((len(ontology.COLORS) - 1) * len(ontology.MATERIALS))
    hidden = (1 - RULE.part_visible) * styles[:, 0].exp()
    plain = RULE.part_visible * (visible + styles[:, 0]).exp()
    looks = RULE.part_visible * (visible[:, None] + styles[:, 1:]).exp() * look_prior
    expected = torch.zeros(parts, NUM_STYLES + 1, dtype=torch.float64)
    for assignment in itertools.product(range(3), repeat=parts):
        shown = sum(a > 0 for a in assignment)
        chosen = sum(a == 2 for a in assignment)
        if chosen != min(3, shown):
            continue
        weights = [hidden[p] if a == 0 else plain[p] if a == 1 else looks[p].sum() for p, a in enumerate(assignment)]
        total = math.prod(weights) / math.comb(shown, chosen)
        for p, a in enumerate(assignment):
            if a == 2:
                expected[p, 2:] += total * looks[p] / looks[p].sum()
            else:
                expected[p, a] += total
    expected /= expected.sum(-1, keepdim=True)
    assert torch.allclose(got, expected, atol=1e-9)


def test_three_clear_looks_leave_no_room_for_a_fourth_and_two_make_the_ambiguous_part_the_third(evidence):
    parts = len(ontology.PARTS["tandem"])
    red_metal = style_index("red", "metal")
    styles = torch.zeros(parts, NUM_STYLES, dtype=torch.float64)
    ambiguous = 3
    styles[ambiguous, red_metal] = 3.0  # a part mask half on a red part: weak evidence
    visible = torch.full((parts,), 6.0, dtype=torch.float64)  # every part in sight
    colour = torch.full((len(ontology.COLORS),), -10.0, dtype=torch.float64)
    colour[ontology.COLORS.index("blue")] = 10.0
    three = styles.clone()
    for p in range(3):
        three[p, style_index("green", "rubber")] = 8.0
    two = styles.clone()  # two clear looks, the other parts but the ambiguous one clearly plain
    for p in range(2):
        two[p, style_index("green", "rubber")] = 8.0
    for p in range(2, parts):
        if p != ambiguous:
            two[p, 0] = 6.0

    def recoloured(tables: torch.Tensor, priors: ScenePriors) -> float:
        return float(_posterior(_with_tables(evidence, visible, tables, colour), priors)[ambiguous, 2:].sum())

    independent = dataclasses.replace(RULE, max_recoloured_parts=None, recoloured_unlike_body=False)
    assert recoloured(three, RULE) < 0.05 < recoloured(three, independent)
    assert recoloured(two, RULE) > 0.9 > recoloured(two, independent)


def test_a_look_in_the_body_colour_is_ruled_out(evidence):
    parts = len(ontology.PARTS["tandem"])
    styles = torch.zeros(parts, NUM_STYLES, dtype=torch.float64)
    styles[0, style_index("blue", "metal")] = 5.0  # the body's colour bleeding into a part mask
    styles[0, style_index("cyan", "metal")] = 4.0
    colour = torch.full((len(ontology.COLORS),), -10.0, dtype=torch.float64)
    colour[ontology.COLORS.index("blue")] = 10.0
    post = _posterior(_with_tables(evidence, torch.full((parts,), 6.0, dtype=torch.float64), styles, colour), RULE)
    assert post[0, 1 + style_index("blue", "metal")] < 1e-6
    assert post[0, 1 + style_index("cyan", "metal")] > post[0, 1 + style_index("blue", "metal")] * 1e4


def test_without_the_rule_the_factor_is_the_independent_one(evidence):
    plain_priors = dataclasses.replace(RULE, max_recoloured_parts=None, recoloured_unlike_body=False)
    assert torch.equal(part_state_loglik(evidence, plain_priors), independent_part_loglik(evidence))
    ruled = part_state_loglik(evidence, RULE)
    assert torch.isfinite(ruled).all()
    padding = len(ontology.PARTS["tandem"])
    assert torch.equal(ruled[:, SUBTYPE, padding:], independent_part_loglik(evidence)[:, SUBTYPE, padding:])
