"""Worked example: new operations written in user code, without touching po3d_ppl.

Height and depth relations for the elevated-aeroplane extension (paper §6). Each operation is one decorated
function over the latent world; registering it makes it available to the program grammar, the type checker, every
inference method (exact, sampling, and the dense and generic references) and the generated docs. A second,
optional decorator gives it a ground-truth semantics so the question engine's reference executor can run it too.

    import height_depth_ops  # registers the operations
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.reasoning import infer
    infer("query_shape(unique(relate_above(unique(filter_shape[bus](scene())))))", simulated_evidence(scene))
"""

from __future__ import annotations

from po3d_ppl.catalogue import register_operation, register_reference

#: Margin (world units) below which two heights or depths count as equal, like CLEVR's spatial relations.
MARGIN = 0.2


@register_operation("relate_above", inputs=["Object"], output="ObjectSet", family="height_depth_example")
def relate_above(world, obj):
    """Objects whose centre is higher than the object's by more than MARGIN."""
    pivot = world.at(obj)
    higher = world.positions[..., 2] - pivot.position[..., 2] > MARGIN
    return world.exists & higher & (world.index != pivot.index)


@register_operation("relate_closer", inputs=["Object"], output="ObjectSet", family="height_depth_example")
def relate_closer(world, obj):
    """Objects nearer to the camera than the object by more than MARGIN."""
    pivot = world.at(obj)
    return world.exists & (pivot.depth - world.depths > MARGIN) & (world.index != pivot.index)


@register_reference("relate_above")
def relate_above_reference(ctx, obj: int) -> frozenset[int]:
    z = [o.position[2] for o in ctx.scene.objects]
    return frozenset(j for j in range(len(z)) if j != obj and z[j] - z[obj] > MARGIN)


@register_reference("relate_closer")
def relate_closer_reference(ctx, obj: int) -> frozenset[int]:
    depth = [o.pixel_coords[2] for o in ctx.scene.objects]
    return frozenset(j for j in range(len(depth)) if j != obj and depth[obj] - depth[j] > MARGIN)
