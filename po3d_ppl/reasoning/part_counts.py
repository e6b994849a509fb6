"""The part-state factor of the scene model, with the world's recolouring rule when the priors hold it.

The world recolours parts by the public generator's rule (spec §1.4, ``world.annotate.choose_recoloured_parts``):
every object has exactly ``min(K, number of visible parts)`` recoloured parts (K = 3), each in a colour unlike the
object's. A prior that recolours each visible part independently at the average rate (0.33) misses both: a part
whose look reads as recoloured must beat odds of 32 to 1 against any one look, even when it is one of the only
three candidates on its object, and a look in the body's own colour (the body's pixels bleeding into a misplaced
part mask) is never ruled out.

The rule couples an object's parts (one recoloured part makes the others less likely), and the per-site engines
(:mod:`po3d_ppl.reasoning.posterior`) need sites no factor couples. So the rule enters as each part's *exact
marginal* under it, given every part's evidence, re-expressed as the independent factor that gives that marginal
under the model's own part-state prior: a forward-backward pass over the object's part slots counting visible and
recoloured parts (at most ``MAX_PARTS + 1`` by ``K + 1`` states). What is dropped is the correlation between two
parts of one object, never a part's own posterior. The object's colour enters through its posterior on its own
(the colour table under the model's uniform colour prior).
"""

from __future__ import annotations

import math

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import DTYPE, NUM_STYLES, SceneEvidence, ScenePriors

#: Part slots each subtype uses (the rest of the ``MAX_PARTS`` axis is padding).
_SLOTS_USED = torch.tensor([len(ontology.PARTS[s]) for s in ontology.SUBTYPES])


def _used_slots(device: torch.device) -> torch.Tensor:
    """``[21, P]`` whether each subtype uses each part slot."""
    return torch.arange(ontology.MAX_PARTS, device=device)[None, :] < _SLOTS_USED.to(device)[:, None]


#: Colour index of each recoloured look (style ``1 + colour * materials + material``).
_LOOK_COLOUR = torch.arange(NUM_STYLES - 1) // len(ontology.MATERIALS)
#: Log-weight standing in for "impossible" (finite, so that no enumeration sum meets inf - inf).
_NEVER = -1e4


def independent_part_loglik(evidence: SceneEvidence) -> torch.Tensor:
    """``[N, 21, P, 18]`` log-likelihood of each part state (hidden, plain, 16 looks) from the tables alone. A hidden
    part shows no recolouring: its attribute reading is scored as the plain style's (column 0); scoring it 0
    instead would give "hidden" a likelihood of 1 for every reading, more than any visible state can reach."""
    return torch.cat([evidence.part_style_loglik[..., :1],
                      evidence.part_visible_logodds.unsqueeze(-1) + evidence.part_style_loglik], dim=-1)


def part_state_loglik(evidence: SceneEvidence, priors: ScenePriors) -> torch.Tensor:
    """The scene model's part-state factor ``[N, 21, P, 18]``: :func:`independent_part_loglik`, or under the
    recolouring rule (``priors.max_recoloured_parts``) the factor whose posterior with the part-state prior is the
    part's exact marginal under the rule (module docstring)."""
    independent = independent_part_loglik(evidence)
    if priors.max_recoloured_parts is None or evidence.num_objects == 0:
        return independent
    log_prior = torch.log(priors.part_state_probs()).to(independent)
    used = _used_slots(independent.device)
    marginal = _rule_marginals(independent + log_prior, evidence, priors, used)
    return torch.where(used[None, :, :, None], marginal - log_prior, independent)


def _rule_marginals(joint: torch.Tensor, evidence: SceneEvidence, priors: ScenePriors, used: torch.Tensor
                    ) -> torch.Tensor:
    """Log posterior ``[N, 21, P, 18]`` of each part's state under the rule, from each part's independent log
    prior x likelihood ``joint`` (the slots not ``used`` are padding: never visible). The independent prior's
    recolouring rate is divided out of the looks and the rule's count put in its place: each look of a recoloured
    part has prior 1 / (number of looks allowed)."""
    device = joint.device
    n, subtypes, slots, _ = joint.shape
    cap = int(priors.max_recoloured_parts)
    rate = priors.part_recoloured
    hidden, plain, looks = joint[..., 0], joint[..., 1], joint[..., 2:]
    plain = plain - math.log(1.0 - rate)
    looks = looks - math.log(rate / (NUM_STYLES - 1)) + _look_log_prior(evidence, priors)[:, None, None, :]
    hidden = torch.where(used, hidden, torch.zeros((), dtype=DTYPE, device=device))
    plain = torch.where(used, plain, torch.full((), _NEVER, dtype=DTYPE, device=device))
    looks = torch.where(used[..., None], looks, torch.full((), _NEVER, dtype=DTYPE, device=device))
    recoloured = torch.logsumexp(looks, -1)

    # states: (visible parts so far 0..slots, recoloured parts so far 0..cap)

    def seen(state: torch.Tensor, recoloured_too: bool, forward: bool) -> torch.Tensor:
        """``state`` moved by one visible part (and one recoloured part), forward or backward in the counts."""
        r = int(recoloured_too)
        if forward:
            return torch.nn.functional.pad(state[..., :-1, :cap + 1 - r], (r, 0, 1, 0), value=_NEVER)
        return torch.nn.functional.pad(state[..., 1:, r:], (0, r, 0, 1), value=_NEVER)

    def advance(state: torch.Tensor, p: int, forward: bool) -> torch.Tensor:
        """Add part ``p`` to the counts (forward) or take it off (backward)."""
        h, pl, rc = (t[..., p, None, None] for t in (hidden, plain, recoloured))
        return torch.logsumexp(torch.stack([state + h, seen(state, False, forward) + pl,
                                            seen(state, True, forward) + rc]), 0)

    visible = torch.arange(slots + 1, device=device, dtype=DTYPE)[:, None]
    chosen = torch.arange(cap + 1, device=device, dtype=DTYPE)[None, :]
    # the rule: exactly min(cap, visible) recoloured, every such choice alike (1 / C(visible, chosen))
    allowed = chosen == torch.clamp(visible, max=cap)
    log_choices = (torch.lgamma(visible + 1) - torch.lgamma(chosen + 1)
                   - torch.lgamma((visible - chosen).clamp_min(0) + 1))
    end = torch.where(allowed, -log_choices, torch.full((), _NEVER, dtype=DTYPE, device=device))

    start = torch.full((n, subtypes, slots + 1, cap + 1), _NEVER, dtype=DTYPE, device=device)
    start[..., 0, 0] = 0.0  # no part counted yet
    forward = [start]
    for p in range(slots):
        forward.append(advance(forward[-1], p, forward=True))
    backward = [end.expand_as(start)]
    for p in range(slots - 1, -1, -1):
        backward.append(advance(backward[-1], p, forward=False))
    backward.reverse()  # backward[p]: parts p.. given the counts before p

    out = torch.empty_like(joint)
    for p in range(slots):
        before, after = forward[p], backward[p + 1]

        def total(after_part: torch.Tensor) -> torch.Tensor:
            return torch.logsumexp((before + after_part).flatten(-2), -1)

        out[:, :, p] = torch.cat([(total(after) + hidden[..., p])[..., None],
                                  (total(seen(after, False, False)) + plain[..., p])[..., None],
                                  total(seen(after, True, False))[..., None] + looks[..., p, :]], -1)
    return out - torch.logsumexp(out, -1, keepdim=True)


def _look_log_prior(evidence: SceneEvidence, priors: ScenePriors) -> torch.Tensor:
    """``[N, 16]`` log prior of each look given that a part is recoloured: uniform over the looks, or with
    ``priors.recoloured_unlike_body`` over those unlike the object's colour (its posterior under the uniform colour
    prior)."""
    n = evidence.num_objects
    if not priors.recoloured_unlike_body:
        return torch.full((n, NUM_STYLES - 1), -math.log(NUM_STYLES - 1), dtype=DTYPE,
                          device=evidence.color_loglik.device)
    colour = torch.softmax(evidence.color_loglik.to(DTYPE), -1)  # [N, colours]
    unlike = 1.0 - colour[:, _LOOK_COLOUR.to(colour.device)]  # [N, 16]
    share = unlike / ((len(ontology.COLORS) - 1) * len(ontology.MATERIALS))
    return torch.log(share.clamp_min(math.exp(_NEVER / 100)))
