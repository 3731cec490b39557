"""Methods from outside the package (docs/design/external-methods.md#external-methods): the versioned protocol
(:mod:`.protocol`), resolving a name to a class (:mod:`.resolve`) and the guarded controller
that runs it (:mod:`.guard`). Only the protocol is re-exported: importing it stays cheap."""

from d3dwa_bullet.external.protocol import (
    ENTRY_POINT_GROUP,
    INTERFACE_VERSION,
    ParameterChooser,
    PlannerInputs,
    VelocityPlanner,
)

__all__ = [
    "ENTRY_POINT_GROUP",
    "INTERFACE_VERSION",
    "ParameterChooser",
    "PlannerInputs",
    "VelocityPlanner",
]
