"""Declarations of the built-in operations (spec §2.3): what each one takes, gives and means.

Implementations live with the stage that owns them: latent-world tensor code in ``po3d_ppl.reasoning.operations``,
ground-truth semantics in ``po3d_ppl.questions.reference``. Both attach here by name.
"""

from __future__ import annotations

from po3d_ppl.catalogue.registry import declare

# ---- core ----------------------------------------------------------------------------------------------------------
family = "core"
declare("scene", [], "ObjectSet", "All objects in the scene.", family=family)
declare("filter_color", ["ObjectSet"], "ObjectSet", "Objects of the given colour.", value="Color", family=family)
declare("filter_material", ["ObjectSet"], "ObjectSet",
        "Objects of the given material.", value="Material", family=family)
declare("filter_size", ["ObjectSet"], "ObjectSet", "Objects of the given size.", value="Size", family=family)
declare("filter_shape", ["ObjectSet"], "ObjectSet",
        "Objects of the given subtype, or of any subtype of the given category "
        "(``car`` matches ``suv``).", value="Shape", family=family)
declare("unique", ["ObjectSet"], "Object",
        "The single object of the set; invalid unless the set has exactly one member.", family=family)
declare("unique", ["PartSet"], "Part",
        "The single part of the set; invalid unless the set has exactly one member.", family=family)
declare("relate", ["Object"], "ObjectSet",
        "Objects in the given spatial relation (left, right, behind, front) "
        "to the object.", value="Relation", family=family)
declare("union", ["ObjectSet", "ObjectSet"], "ObjectSet", "Objects in either set.", family=family)
declare("union", ["PartSet", "PartSet"], "PartSet", "Parts in either set.", family=family)
declare("intersect", ["ObjectSet", "ObjectSet"], "ObjectSet", "Objects in both sets.", family=family)
declare("intersect", ["PartSet", "PartSet"], "PartSet", "Parts in both sets.", family=family)
declare("count", ["ObjectSet"], "Integer", "Number of objects in the set.", family=family)
declare("count", ["PartSet"], "Integer", "Number of parts in the set.", family=family)
declare("exist", ["ObjectSet"], "Bool", "Whether the set is non-empty.", family=family)
declare("exist", ["PartSet"], "Bool", "Whether the part set is non-empty.", family=family)
declare("query_color", ["Object"], "Color", "Colour of the object.", family=family)
declare("query_material", ["Object"], "Material", "Material of the object.", family=family)
declare("query_size", ["Object"], "Size", "Size of the object.", family=family)
declare("query_shape", ["Object"], "Shape", "Subtype of the object (e.g. ``suv``).", family=family)
declare("same_color", ["Object"], "ObjectSet",
        "Other objects with the same color as the object (exact match, no hypernyms).", family=family)
declare("same_material", ["Object"], "ObjectSet",
        "Other objects with the same material as the object (exact match, no hypernyms).", family=family)
declare("same_size", ["Object"], "ObjectSet",
        "Other objects with the same size as the object (exact match, no hypernyms).", family=family)
declare("same_shape", ["Object"], "ObjectSet",
        "Other objects with the same subtype as the object (exact match, no hypernyms).", family=family)
declare("equal_color", ["Color", "Color"], "Bool", "Whether two Color values are equal.", family=family)
declare("equal_material", ["Material", "Material"], "Bool", "Whether two Material values are equal.", family=family)
declare("equal_size", ["Size", "Size"], "Bool", "Whether two Size values are equal.", family=family)
declare("equal_shape", ["Shape", "Shape"], "Bool", "Whether two Shape values are equal.", family=family)
declare("equal_integer", ["Integer", "Integer"], "Bool", "Whether two counts are equal.", family=family)
declare("less_than", ["Integer", "Integer"], "Bool", "Whether the first count is smaller.", family=family)
declare("greater_than", ["Integer", "Integer"], "Bool", "Whether the first count is larger.", family=family)

# ---- parts ---------------------------------------------------------------------------------------------------------
family = "parts"
declare("object2part", ["ObjectSet"], "PartSet",
        "The recoloured parts (the parts that have attributes) of the objects.", family=family)
declare("object2part", ["Object"], "PartSet", "The recoloured parts of the object.", family=family)
declare("object2part_all", ["ObjectSet"], "PartSet",
        "The recoloured parts and the occluded parts of the objects.", family=family)
declare("object2part_all", ["Object"], "PartSet",
        "The recoloured parts and the occluded parts of the object.", family=family)
declare("part2object", ["Part"], "ObjectSet", "The object the part belongs to.", family=family)
declare("part2object", ["PartSet"], "ObjectSet", "The objects owning at least one of the parts.", family=family)
declare("partfilter_color", ["PartSet"], "PartSet", "Parts of the given colour.", value="Color", family=family)
declare("partfilter_material", ["PartSet"], "PartSet",
        "Parts of the given material.", value="Material", family=family)
declare("partfilter_size", ["PartSet"], "PartSet",
        "Parts of the given size (a recoloured part carries its object's size).", value="Size", family=family)
declare("partfilter_partname", ["PartSet"], "PartSet",
        "Parts named by the value's words (``back_left_wheel`` matches "
        "``wheel_back_left`` too), or whose coarse name it is (``wheel`` "
        "matches every wheel).", value="Partname", family=family)
declare("partquery_color", ["Part"], "Color",
        "Colour of the part (invalid for a part without attributes).", family=family)
declare("partquery_material", ["Part"], "Material",
        "Material of the part (invalid for a part without attributes).", family=family)
declare("partquery_size", ["Part"], "Size",
        "Size of the part (its object's size; invalid for a part without attributes).", family=family)
declare("partquery_partname", ["Part"], "Partname", "Raw name of the part (e.g. ``wheel_back_left``).", family=family)

# ---- pose ----------------------------------------------------------------------------------------------------------
family = "pose"
declare("filter_pose", ["ObjectSet"], "ObjectSet",
        "Objects facing the given direction (``front_pose`` ...); objects in a "
        "dead zone match none.", value="Pose", family=family)
declare("query_pose", ["Object"], "Direction",
        "Direction the object faces (front, back, left, right); invalid in a dead zone.", family=family)
declare("same_pose", ["Object"], "ObjectSet",
        "Other objects facing the same direction as the object (azimuths compared with the "
        "45/135 degree rule); none when the object itself faces a dead-zone direction.", family=family)
declare("vertical_pose", ["Object"], "ObjectSet",
        "Other objects facing perpendicular to the object (azimuths compared with the 45/135 "
        "degree rule); none when the object itself faces a dead-zone direction.", family=family)
declare("opposite_pose", ["Object"], "ObjectSet",
        "Other objects facing opposite to the object (azimuths compared with the 45/135 degree "
        "rule); none when the object itself faces a dead-zone direction.", family=family)

# ---- occlusion -----------------------------------------------------------------------------------------------------
family = "occlusion"
declare("filter_occludee", ["ObjectSet"], "ObjectSet", "Objects that are occluded.", family=family)
declare("partfilter_occludee", ["PartSet"], "PartSet", "Parts that are occluded.", family=family)
declare("partquery_occlusion", ["Part"], "Bool", "Whether the part is occluded.", family=family)
declare("filter_occluder", ["ObjectSet"], "ObjectSet",
        "Objects that occlude some object or part (no template emits it; the exact engine "
        "defers to sampling).", family=family)
declare("relate_occluded", ["Object"], "ObjectSet", "The objects that occlude the object.", family=family)
declare("relate_occluding", ["Object"], "ObjectSet", "The objects that the object occludes.", family=family)
declare("relate_occluding_part", ["Object"], "PartSet",
        "The parts (of other objects) that the object occludes.", family=family)
declare("relate_part_occluded", ["Part"], "ObjectSet", "The objects that occlude the part.", family=family)
