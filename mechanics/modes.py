"""Contact-mode statistics: dwell time per 6-bit mode mask and the dwell-filtered distinct modes (SPEC §4.6)."""
import numpy as np

REGION_LABELS = ("c1", "c2", "c3", "c4", "c5", "c6")


def mode_label(mask: int) -> str:
    """'c1+c5' style label of a mode mask; 'free' for 0."""
    regions = [label for bit, label in enumerate(REGION_LABELS) if int(mask) >> bit & 1]
    return "+".join(regions) if regions else "free"


def mode_dwell(times: np.ndarray, modes: np.ndarray) -> dict[int, float]:
    """Cumulative dwell per mode over accepted steps: each step's length goes to the mode at its end."""
    dwell: dict[int, float] = {}
    steps = np.diff(times)
    for mask, step in zip(modes[1:].astype(int), steps):
        dwell[mask] = dwell.get(mask, 0.0) + float(step)
    return dwell


def distinct_modes(dwell: dict[int, float], min_dwell: float) -> list[int]:
    """Modes whose cumulative dwell is at least tau_min, sorted (free flight counts if it dwells)."""
    return sorted(mask for mask, total in dwell.items() if total >= min_dwell)
