"""Contact-mode statistics: dwell time per 6-bit mode mask and the dwell-filtered distinct modes (docs/model.md §4.6)."""
import numpy as np

REGION_LABELS = ("c1", "c2", "c3", "c4", "c5", "c6")


def mode_label(mask: int) -> str:
    """'c1+c5' style label of a mode mask; 'free' for 0."""
    regions = [label for bit, label in enumerate(REGION_LABELS) if int(mask) >> bit & 1]
    return "+".join(regions) if regions else "free"


MODE_COUNT = 64                    # 6-bit masks


def mode_dwell_array(times: np.ndarray, modes: np.ndarray) -> np.ndarray:
    """Dwell per mode mask (index = mask) over accepted steps: each step's length goes to the mode at its end."""
    return np.bincount(modes[1:].astype(np.int64), weights=np.diff(times), minlength=MODE_COUNT)


def mode_dwell(times: np.ndarray, modes: np.ndarray) -> dict[int, float]:
    """Cumulative dwell per mode that occurs, as {mask: seconds}."""
    dwell = mode_dwell_array(times, modes)
    return {int(mask): float(dwell[mask]) for mask in np.flatnonzero(dwell)}


def distinct_modes(dwell: dict[int, float], min_dwell: float) -> list[int]:
    """Modes whose cumulative dwell is at least tau_min, sorted (free flight counts if it dwells)."""
    return sorted(mask for mask, total in dwell.items() if total >= min_dwell)
