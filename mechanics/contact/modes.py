"""Contact modes: labels and the dwell-filtered distinct modes (docs/model.md §4.6). The dwell of every mode is
accumulated in the time loop (mechanics.loop.windows)."""
from .regions import REGION_COUNT, REGION_LABELS

MODE_COUNT = 1 << REGION_COUNT                    # one bit per region


def mode_label(mask: int) -> str:
    """'c1+c5' style label of a mode mask; 'free' for 0."""
    regions = [label for bit, label in enumerate(REGION_LABELS) if int(mask) >> bit & 1]
    return "+".join(regions) if regions else "free"


def distinct_modes(dwell: dict[int, float], min_dwell: float) -> list[int]:
    """Modes whose cumulative dwell is at least tau_min, sorted (free flight counts if it dwells)."""
    return sorted(mask for mask, total in dwell.items() if total >= min_dwell)
