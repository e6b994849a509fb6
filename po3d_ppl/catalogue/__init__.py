"""The operation catalogue, shared by every stage: names, signatures, types, docs and value vocabularies.

Torch-free. Importing it declares the built-in operations (:mod:`po3d_ppl.catalogue.builtin`); the reasoning and
question stages attach their implementations by name when they load.
"""

from po3d_ppl.catalogue import builtin  # noqa: F401  (declares the built-in operations)
from po3d_ppl.catalogue.registry import (
    ALL_TYPES,
    ENTITY_TYPES,
    REGISTRY,
    VALUE_TYPES,
    Operation,
    OperationRegistry,
    RegistryError,
    Signature,
    declare,
    register_operation,
    register_reference,
    register_world,
    value_vocabulary,
)

__all__ = [
    "ALL_TYPES", "ENTITY_TYPES", "VALUE_TYPES", "REGISTRY", "Operation", "OperationRegistry", "RegistryError",
    "Signature", "declare", "register_operation", "register_reference", "register_world", "value_vocabulary",
]
