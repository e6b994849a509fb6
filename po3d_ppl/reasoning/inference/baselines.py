"""The two comparison baselines; the only inference code that does not derive answers from the compiled model.

- ``thresholded`` (NS-VQA style): take the most probable value of every latent and run the program on that one
  scene. Certain answers, no notion of doubt.
- ``soft`` (P-NSVQA style): propagate independent probabilities through the program: a set is a vector of
  membership probabilities, ``unique`` normalises it into a distribution over objects, queries mix attribute
  marginals, counts assume independent members. Correlations between steps (the same object's colour filtered
  twice, the referent of ``unique`` versus the other objects) are ignored, which is exactly what the probabilistic
  program fixes.

Both implement the built-in operations only (``soft`` raises for an operation it has no rule for).
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from po3d_ppl import ontology
from po3d_ppl.catalogue.semantics import PUBLIC
from po3d_ppl.errors import Po3dError
from po3d_ppl.evidence import DTYPE, SceneEvidence
from po3d_ppl.language.interpret import interpret
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.concrete_world import most_probable_world
from po3d_ppl.reasoning.posterior import SitePosteriors
from po3d_ppl.reasoning.world import pose_label_ids, pose_relation_ids
from po3d_ppl.world.scene import RELATION_EPS


class SoftUnsupported(Po3dError):
    """The soft baseline has no rule for an operation (user-registered operations, for instance)."""


def thresholded_answer(typed, post: SitePosteriors, evidence: SceneEvidence, semantics: str = "intended") -> int:
    """The answer id (``values.INVALID`` when the execution is invalid) of the program run on the one most probable
    scene."""
    world = most_probable_world(post, evidence)
    value = int(run_program(typed, world, semantics).reshape(-1)[0])
    return value if bool(world.valid.reshape(-1)[0]) else values.INVALID


# ---- soft (P-NSVQA) --------------------------------------------------------------------------------------------


class _Marginals:
    """Per-object and per-part marginal probabilities, the soft executor's whole view of the scene."""

    def __init__(self, post: SitePosteriors, evidence: SceneEvidence):
        p = post.probs
        self.n = n = evidence.num_objects
        self.exists = p["exists"][:, 1]
        self.subtype, self.color, self.material, self.size = p["subtype"], p["color"], p["material"], p["size"]
        # the pose marginal [N, K]: mixed over the subtype hypotheses unless it is the same under each
        self.pose_probs = post.shared.get("pose")
        if self.pose_probs is None:
            self.pose_probs = torch.einsum("ns,nsk->nk", p["subtype"], p["pose"])
        self.pose_degree = evidence.pose_support  # [N, K]
        labels = pose_label_ids(evidence.pose_support)  # [N, K]
        self.pose_label = torch.stack([(self.pose_probs * (labels == d)).sum(-1) for d in range(len(ontology.POSES))],
                                      -1)
        self.occluded = p["occluded"][:, 1]
        self.occludes = p["occludes"][..., 1] * (1 - torch.eye(n, dtype=DTYPE))  # [i, j]: i occluded by j
        sub = self.subtype  # [N, 21]
        names = values.subtype_part_names()  # [21, P]
        self.part_valid = torch.einsum("ns,sp->np", sub, (names >= 0).to(DTYPE))
        self.part_name = torch.einsum("ns,spr->npr", sub,
                                      torch.nn.functional.one_hot(names.clamp(min=0), len(ontology.RAW_PART_NAMES))
                                      .to(DTYPE) * (names >= 0).unsqueeze(-1))
        state = torch.einsum("ns,nspk->npk", sub, p["part_state"])  # [N, P, 18]
        self.part_color = torch.stack([(state * (values.state_color() == c)).sum(-1)
                                       for c in range(len(ontology.COLORS))], -1)
        self.part_material = torch.stack([(state * (values.state_material() == m)).sum(-1)
                                          for m in range(len(ontology.MATERIALS))], -1)
        self.part_recoloured = self.part_color.sum(-1) * self.part_valid
        self.part_occluded = torch.einsum("ns,nsp->np", sub, p["part_occluded"][..., 1]) * self.part_valid
        self.part_occludes = torch.einsum("ns,nspj->npj", sub, p["part_occludes"][..., 1])  # [N, P, N_j]
        self.positions, self.depths, self.directions = evidence.positions, evidence.depths, evidence.directions


def _normalise(weights: torch.Tensor) -> torch.Tensor:
    total = weights.sum()
    return weights / total if total > 0 else torch.zeros_like(weights)


def _poisson_binomial(p: torch.Tensor, size: int) -> torch.Tensor:
    dist = torch.zeros(size + 1, dtype=DTYPE)
    dist[0] = 1.0
    for q in p.flatten():
        dist = torch.cat([dist[:1] * (1 - q), dist[1:] * (1 - q) + dist[:-1] * q])
    return dist


SoftRules = dict[tuple[str, tuple[str, ...]], Callable]


def soft_rules(post: SitePosteriors, evidence: SceneEvidence, semantics: str = "intended") -> SoftRules:
    """Soft semantics per (operation, input types) over one scene's marginals (they depend on nothing else), under
    ``semantics`` (the public rules: :func:`_public_soft_rules`)."""
    m = _Marginals(post, evidence)
    n = m.n
    not_self = 1 - torch.eye(n, dtype=DTYPE)
    dist_over = lambda table: lambda x: x @ table  # noqa: E731  object distribution -> value distribution
    shape_match = values.shape_match_table().to(DTYPE)  # [values, 21]
    part_match = values.partname_match_table()[:, :-1].to(DTYPE)  # [values, 85]

    def related(relation: str):
        if relation in ("closer", "farther"):
            offset = m.depths.unsqueeze(0) - m.depths.unsqueeze(1)  # [k, j] = d_j - d_k
            offset = offset if relation == "farther" else -offset
        else:
            proj = m.positions @ m.directions[relation]
            offset = proj.unsqueeze(0) - proj.unsqueeze(1)
        return (offset > RELATION_EPS).to(DTYPE) * not_self

    def same(table):
        return lambda x: m.exists * (x @ ((table @ table.T) * not_self))

    def pose_relation(code: int):
        rel = (pose_relation_ids(m.pose_degree[:, None, :, None], m.pose_degree[None, :, None, :]) == code)
        valid = (pose_label_ids(m.pose_degree) != values.INVALID).to(DTYPE)  # reference objects [k, K]
        joint = torch.einsum("ka,jb,ka,kjab->kj", m.pose_probs, m.pose_probs, valid, rel.to(DTYPE)) * not_self
        return lambda x: m.exists * (x @ joint)

    def compare(op):
        def rule(a, b):
            p = sum(float(a[u] * b[v]) for u in range(len(a)) for v in range(len(b)) if op(u, v))
            return torch.tensor([1 - p, p], dtype=DTYPE)
        return rule

    rules = {
        ("scene", ()): lambda: m.exists,
        ("filter_color", ("ObjectSet",)): lambda s, v: s * m.color[:, ontology.COLORS.index(v)],
        ("filter_material", ("ObjectSet",)): lambda s, v: s * m.material[:, ontology.MATERIALS.index(v)],
        ("filter_size", ("ObjectSet",)): lambda s, v: s * m.size[:, ontology.SIZES.index(v)],
        ("filter_shape", ("ObjectSet",)): lambda s, v: s * (m.subtype @ shape_match[ontology.SHAPE_VALUES.index(v)]),
        ("filter_pose", ("ObjectSet",)):
            lambda s, v: s * m.pose_label[:, ontology.POSES.index(v.removesuffix("_pose"))],
        ("unique", ("ObjectSet",)): _normalise,
        ("unique", ("PartSet",)): _normalise,
        ("relate", ("Object",)): lambda x, v: m.exists * (x @ related(v)),
        ("union", ("ObjectSet", "ObjectSet")): lambda a, b: 1 - (1 - a) * (1 - b),
        ("intersect", ("ObjectSet", "ObjectSet")): lambda a, b: a * b,
        ("union", ("PartSet", "PartSet")): lambda a, b: 1 - (1 - a) * (1 - b),
        ("intersect", ("PartSet", "PartSet")): lambda a, b: a * b,
        ("count", ("ObjectSet",)): lambda s: _poisson_binomial(s, n),
        ("exist", ("ObjectSet",)): lambda s: torch.stack([torch.prod(1 - s), 1 - torch.prod(1 - s)]),
        ("exist", ("PartSet",)): lambda s: torch.stack([torch.prod(1 - s), 1 - torch.prod(1 - s)]),
        ("query_color", ("Object",)): dist_over(m.color),
        ("query_material", ("Object",)): dist_over(m.material),
        ("query_size", ("Object",)): dist_over(m.size),
        ("query_shape", ("Object",)): dist_over(m.subtype),
        ("query_pose", ("Object",)): dist_over(m.pose_label),
        ("same_color", ("Object",)): same(m.color),
        ("same_material", ("Object",)): same(m.material),
        ("same_size", ("Object",)): same(m.size),
        ("same_shape", ("Object",)): same(m.subtype),
        ("same_pose", ("Object",)): pose_relation(0),
        ("vertical_pose", ("Object",)): pose_relation(1),
        ("opposite_pose", ("Object",)): pose_relation(2),
        ("equal_integer", ("Integer", "Integer")): compare(lambda u, v: u == v),
        ("less_than", ("Integer", "Integer")): compare(lambda u, v: u < v),
        ("greater_than", ("Integer", "Integer")): compare(lambda u, v: u > v),
        ("object2part", ("ObjectSet",)): lambda s: s.unsqueeze(-1) * m.part_recoloured,
        ("object2part", ("Object",)): lambda x: x.unsqueeze(-1) * m.part_recoloured,
        ("object2part_all", ("ObjectSet",)):
            lambda s: s.unsqueeze(-1) * (1 - (1 - m.part_recoloured) * (1 - m.part_occluded)),
        ("object2part_all", ("Object",)):
            lambda x: x.unsqueeze(-1) * (1 - (1 - m.part_recoloured) * (1 - m.part_occluded)),
        ("part2object", ("PartSet",)): lambda t: 1 - torch.prod(1 - t, -1),
        ("part2object", ("Part",)): lambda y: y.sum(-1),
        ("partfilter_color", ("PartSet",)): lambda t, v: t * m.part_color[..., ontology.COLORS.index(v)],
        ("partfilter_material", ("PartSet",)): lambda t, v: t * m.part_material[..., ontology.MATERIALS.index(v)],
        ("partfilter_size", ("PartSet",)):
            lambda t, v: t * m.part_recoloured * m.size[:, ontology.SIZES.index(v)].unsqueeze(-1),
        ("partfilter_partname", ("PartSet",)):
            lambda t, v: t * (m.part_name @ part_match[ontology.PARTNAME_VALUES.index(v)]),
        ("partquery_color", ("Part",)): lambda y: torch.einsum("np,npc->c", y, m.part_color),
        ("partquery_material", ("Part",)): lambda y: torch.einsum("np,npc->c", y, m.part_material),
        ("partquery_size", ("Part",)): lambda y: torch.einsum("np,np,nc->c", y, m.part_recoloured, m.size),
        ("partquery_partname", ("Part",)): lambda y: torch.einsum("np,npr->r", y, m.part_name),
        ("filter_occludee", ("ObjectSet",)): lambda s: s * m.occluded,
        ("partfilter_occludee", ("PartSet",)): lambda t: t * m.part_occluded,
        ("partquery_occlusion", ("Part",)):
            lambda y: torch.stack([(y * (1 - m.part_occluded)).sum(), (y * m.part_occluded).sum()]),
        ("filter_occluder", ("ObjectSet",)): lambda s: s * (1 - torch.prod(1 - m.exists.unsqueeze(-1) * m.occludes, 0)
                                                            * torch.prod(1 - (m.part_valid.unsqueeze(-1) * m.part_occludes
                                                                              * not_self.unsqueeze(1)).flatten(0, 1), 0)),
        ("relate_occluded", ("Object",)): lambda x: m.exists * (x @ m.occludes),
        ("relate_occluding", ("Object",)): lambda x: m.exists * (m.occludes @ x),
        ("relate_occluding_part", ("Object",)): lambda x: m.part_valid * (m.part_occludes @ x),
        ("relate_part_occluded", ("Part",)): lambda y: m.exists * torch.einsum("np,npj->j", y, m.part_occludes),
    }
    for t in ("Color", "Material", "Size", "Shape"):
        rules[(f"equal_{t.lower()}", (t, t))] = lambda a, b: torch.stack([1 - (a * b).sum(), (a * b).sum()])
    if semantics == PUBLIC:
        rules.update(_public_soft_rules(m, not_self, rules))
    return rules


def _public_soft_rules(m: _Marginals, not_self: torch.Tensor, intended: SoftRules) -> SoftRules:
    """The public rules (docs/semantics.md; ``po3d_ppl.reasoning.semantics`` for the latent worlds) on the
    independent marginals. ``relate_occluding_part``'s "last part" orders parts by their most probable
    recoloured state."""
    from po3d_ppl.reasoning import semantics as public

    def table(t: torch.Tensor) -> torch.Tensor:
        return t.to(DTYPE)

    labels = public.public_pose_labels(m.pose_degree)  # [N, K]
    pose_label = torch.stack([(m.pose_probs * (labels == d)).sum(-1) for d in range(len(ontology.POSES))]
                             + [(m.pose_probs * (labels == values.INVALID)).sum(-1)], -1)  # [N, 5]: 'None' last
    colors, materials, sizes = (table(t()) for t in (public._color_table, public._material_table, public._size_table))
    shape_match = table(public.public_shape_table())
    part_match = table(public.public_partname_table()[:, :-1])

    def pose_relation(code: int):
        rel = pose_relation_ids(m.pose_degree[:, None, :, None], m.pose_degree[None, :, None, :]) == code
        valid = (labels != values.INVALID).to(DTYPE)
        joint = torch.einsum("ka,jb,ka,kjab->kj", m.pose_probs, m.pose_probs, valid, rel.to(DTYPE)) * not_self
        return lambda x: m.exists * (x @ joint)

    def relate(x, value):
        if value not in public.PUBLIC_RELATIONS:
            raise public.SemanticsError(f"relate[{value}] has no public meaning: the public scene files hold only "
                                        f"the {', '.join(public.PUBLIC_RELATIONS)} relationships")
        return intended[("relate", ("Object",))](x, value)

    occluder = intended[("filter_occluder", ("ObjectSet",))]

    n, p = m.part_valid.shape
    plain = (m.part_recoloured < 0.5).to(DTYPE)
    order = ((torch.arange(n).view(n, 1) * 2 + plain) * p + torch.arange(p).view(1, p)).flatten()
    later = (order.unsqueeze(0) > order.unsqueeze(1)).to(DTYPE)  # [q, r]: r comes after q

    def last_part(t: torch.Tensor) -> torch.Tensor:
        flat = t.flatten()
        none_later = torch.exp(later @ torch.log1p(-flat.clamp(max=1 - 1e-15)))
        return (flat * none_later).reshape(n, p)

    return {
        ("filter_color", ("ObjectSet",)): lambda s, v: s * (m.color @ colors[ontology.COLORS.index(v)]),
        ("filter_material", ("ObjectSet",)): lambda s, v: s * (m.material @ materials[ontology.MATERIALS.index(v)]),
        ("filter_size", ("ObjectSet",)): lambda s, v: s * (m.size @ sizes[ontology.SIZES.index(v)]),
        ("filter_shape", ("ObjectSet",)): lambda s, v: s * (m.subtype @ shape_match[ontology.SHAPE_VALUES.index(v)]),
        ("partfilter_color", ("PartSet",)): lambda t, v: t * (m.part_color @ colors[ontology.COLORS.index(v)]),
        ("partfilter_material", ("PartSet",)):
            lambda t, v: t * (m.part_material @ materials[ontology.MATERIALS.index(v)]),
        ("partfilter_size", ("PartSet",)):
            lambda t, v: t * m.part_recoloured * (m.size @ sizes[ontology.SIZES.index(v)]).unsqueeze(-1),
        ("partfilter_partname", ("PartSet",)):
            lambda t, v: t * (m.part_name @ part_match[ontology.PARTNAME_VALUES.index(v)]),
        ("filter_pose", ("ObjectSet",)):
            lambda s, v: s * pose_label[:, ontology.POSES.index(v.removesuffix("_pose"))],
        ("query_pose", ("Object",)): lambda x: x @ pose_label,
        ("same_pose", ("Object",)): pose_relation(0),
        ("vertical_pose", ("Object",)): pose_relation(1),
        ("opposite_pose", ("Object",)): pose_relation(2),
        ("relate_occluding_part", ("Object",)): lambda x: last_part(m.part_valid * (m.part_occludes @ x)),
        ("relate", ("Object",)): relate,
        ("filter_occluder", ("ObjectSet",)): lambda s: occluder(torch.ones_like(s)),  # ignores its input
    }


def soft_distribution(typed, rules: SoftRules, num_values: int) -> tuple[torch.Tensor, float]:
    """Answer probabilities per id and the invalid mass under independent-probability propagation (``rules`` from
    :func:`soft_rules`)."""
    def implementation(op):
        rule = rules.get((op.name, op.inputs))
        if rule is None:
            raise SoftUnsupported(f"the soft baseline has no rule for {op.name}{op.signature}")
        return rule

    result = interpret(typed, implementation).result
    answer = result.to(DTYPE).reshape(-1)
    probs = torch.zeros(num_values, dtype=DTYPE)
    probs[: answer.shape[0]] = answer[:num_values]
    return probs, float(max(0.0, 1.0 - probs.sum()))
