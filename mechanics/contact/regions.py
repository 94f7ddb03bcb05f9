"""The contact regions, declared once (docs/model.md §1.3, §4).

Each region has a label, the feature pair it describes, the body the vane touches there (rotor or stator: where
the reaction goes, docs/model.md §5.4), its slot in the contact memory of impact velocities (c5 and c6 share
one: the tip touches the stator at one point, on one side or the other of the tip apex), the detector that finds
its candidate and the side (+1 leading, -1 trailing) the detector looks at. The detectors live in
mechanics.contact.detection (`region_candidate` dispatches on the detector kind), the forces in
mechanics.contact.contact_forces; the per-region output columns (normal_force_k, ...), the memory, the mode masks and
the region groups of the figures follow from this table (docs/model.md §14.1).
"""
from __future__ import annotations

from typing import NamedTuple

ROTOR, STATOR = 0, 1
# detector kinds (docs/model.md §4.2-§4.4b): slot-mouth edge, bottom corner on the slot wall, tip on the
# stator, bottom corner on the slot bottom
SLOT_MOUTH, WALL_CORNER, TIP, FLOOR_CORNER = range(4)


class Region(NamedTuple):
    label: str
    description: str
    body: int              # ROTOR or STATOR
    memory_slot: int       # index into the impact-velocity memory
    detector: int          # SLOT_MOUTH, WALL_CORNER, TIP or FLOOR_CORNER
    side: float            # +1 leading, -1 trailing (for TIP: the side of the apex, sign of psi_c)


REGIONS = (
    Region("c1", "slot-mouth edge, leading side", ROTOR, 0, SLOT_MOUTH, 1.0),
    Region("c2", "slot-mouth edge, trailing side", ROTOR, 1, SLOT_MOUTH, -1.0),
    Region("c3", "vane bottom corner on the slot wall, leading side", ROTOR, 2, WALL_CORNER, 1.0),
    Region("c4", "vane bottom corner on the slot wall, trailing side", ROTOR, 3, WALL_CORNER, -1.0),
    Region("c5", "vane tip on the stator, leading side of the apex (psi_c > 0)", STATOR, 4, TIP, 1.0),
    Region("c6", "vane tip on the stator, trailing side of the apex (psi_c < 0)", STATOR, 4, TIP, -1.0),
    Region("c7", "vane bottom corner on the slot bottom, leading side", ROTOR, 5, FLOOR_CORNER, 1.0),
    Region("c8", "vane bottom corner on the slot bottom, trailing side", ROTOR, 6, FLOOR_CORNER, -1.0),
)
REGION_COUNT = len(REGIONS)
REGION_LABELS = tuple(region.label for region in REGIONS)
MEMORY_SLOTS = max(region.memory_slot for region in REGIONS) + 1
SLOT_REGIONS = tuple(i for i, region in enumerate(REGIONS) if region.body == ROTOR)
TIP_REGIONS = tuple(i for i, region in enumerate(REGIONS) if region.body == STATOR)
# integer views for the compiled loop (numba reads global tuples of numbers as constants)
REGION_BODY = tuple(region.body for region in REGIONS)
REGION_MEMORY_SLOT = tuple(region.memory_slot for region in REGIONS)
REGION_DETECTOR = tuple(region.detector for region in REGIONS)
REGION_SIDE = tuple(region.side for region in REGIONS)


def labels_of(regions) -> str:
    """'c1, c2, c3' style list of the labels of region indices."""
    return ", ".join(REGION_LABELS[i] for i in regions)
