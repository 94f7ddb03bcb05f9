"""The six contact regions, declared once (docs/model.md §1.3, §4).

Each region has a label, the feature pair it describes, the body the vane touches there (rotor or stator: where
the reaction goes, docs/model.md §5.4) and its slot in the contact memory of impact velocities (c5 and c6 share
one: the tip touches the stator at one point, on one side or the other of the tip apex). The detectors live in
mechanics.contact, the forces in mechanics.contact_forces; the per-region output columns (normal_force_k, ...)
follow from REGION_COUNT (mechanics.outputs).
"""
from __future__ import annotations

from typing import NamedTuple

ROTOR, STATOR = 0, 1


class Region(NamedTuple):
    label: str
    description: str
    body: int              # ROTOR or STATOR
    memory_slot: int       # index into the impact-velocity memory


REGIONS = (
    Region("c1", "slot-mouth edge, leading side", ROTOR, 0),
    Region("c2", "slot-mouth edge, trailing side", ROTOR, 1),
    Region("c3", "vane bottom corner on the slot wall, leading side", ROTOR, 2),
    Region("c4", "vane bottom corner on the slot wall, trailing side", ROTOR, 3),
    Region("c5", "vane tip on the stator, leading side of the apex (psi_c > 0)", STATOR, 4),
    Region("c6", "vane tip on the stator, trailing side of the apex (psi_c < 0)", STATOR, 4),
)
REGION_COUNT = len(REGIONS)
REGION_LABELS = tuple(region.label for region in REGIONS)
MEMORY_SLOTS = max(region.memory_slot for region in REGIONS) + 1
TIP_MEMORY_SLOT = REGIONS[4].memory_slot
SLOT_REGIONS = tuple(i for i, region in enumerate(REGIONS) if region.body == ROTOR)     # c1-c4
TIP_REGIONS = tuple(i for i, region in enumerate(REGIONS) if region.body == STATOR)    # c5, c6
# integer views for the compiled loop (numba reads global tuples of numbers as constants)
REGION_BODY = tuple(region.body for region in REGIONS)
REGION_MEMORY_SLOT = tuple(region.memory_slot for region in REGIONS)
