"""Per-lobe accumulation inside the time loop, from which every per-lobe and per-revolution figure follows
(docs/model.md §4.6, §6.4).

The loop lands on every valley (every 2 pi / z of rotor angle), so lobes are exact windows and a revolution is z
consecutive lobes. The `window` array holds the output row at the start of the current lobe and what accumulates
over it at each accepted step: trapezoidal time integrals of the `INTEGRATED_COLUMNS` (stator and gap moments; the
works are states, their differences come from the start and end rows), the largest normal force per region and the
largest |tilt|, and the dwell of every extended contact mode. At each valley the loop writes one lobe record
(`RECORD_*` layout: the start row, the end row, the accumulators) and starts the next window;
mechanics.performance turns records into figures. Nothing of this runs in Python per accepted step.

Extended mode key (docs/model.md §4.6): the mask of touching regions (one bit per region, MASKS values) plus, for
c1 and c2 when touching, their slot-mouth candidate type: key = mask + MASKS (type_1 + 4 type_2), 16 MASKS keys. Counting distinct masks only
(summing over the types) gives the regions-only count.
"""
import math

import numpy as np

from ...kernels.kernel import kernel

from ..contact.detection import CANDIDATE_TYPES
from .outputs import O, OUTPUT_SIZE
from ..contact.regions import REGION_COUNT

MASKS = 1 << REGION_COUNT
MODE_KEYS = MASKS * CANDIDATE_TYPES * CANDIDATE_TYPES
# columns integrated over time (trapezoidal over the accepted steps); their integrals come first in the accumulators
INTEGRATED_COLUMNS = (O.stator_reaction_moment, O.gap_moment)
INTEGRALS = len(INTEGRATED_COLUMNS)
# accumulators (offsets into the accumulator part of a window or record)
ACC_STATOR_MOMENT, ACC_GAP_MOMENT = range(INTEGRALS)
ACC_MAX_TILT = INTEGRALS
ACC_LAW_EXCESS = ACC_MAX_TILT + 1
ACC_MAX_FORCE = ACC_LAW_EXCESS + 1                 # one per region
ACC_DWELL = ACC_MAX_FORCE + REGION_COUNT           # one per extended mode key
ACCUMULATOR_SIZE = ACC_DWELL + MODE_KEYS
# window = [start row | accumulators | previous accepted row's time and integrated columns]
WINDOW_START = 0
WINDOW_ACCUMULATORS = OUTPUT_SIZE
WINDOW_PREVIOUS = WINDOW_ACCUMULATORS + ACCUMULATOR_SIZE
WINDOW_SIZE = WINDOW_PREVIOUS + 1 + INTEGRALS
# lobe record = [lobe index | start row | end row | accumulators]
RECORD_LOBE = 0
RECORD_START = 1
RECORD_END = RECORD_START + OUTPUT_SIZE
RECORD_ACCUMULATORS = RECORD_END + OUTPUT_SIZE
RECORD_SIZE = RECORD_ACCUMULATORS + ACCUMULATOR_SIZE


@kernel
def mode_key(out):
    """Extended mode key of an output row (module docstring)."""
    mask = int(out[O.contact_mode])
    first = int(out[O.mouth_candidate_1]) if mask & 1 else 0
    second = int(out[O.mouth_candidate_2]) if mask & 2 else 0
    return mask + MASKS * (first + CANDIDATE_TYPES * second)


def new_window(initial_row: np.ndarray, at_valley: bool) -> np.ndarray:
    """The window at the start of a run whose first output row is `initial_row`: opened there if the run starts on
    a valley, else NaN-started (its lobe is incomplete and yields no figures; its steps still count in the run-long
    dwell)."""
    window = np.zeros(WINDOW_SIZE)
    window[WINDOW_START:WINDOW_START + OUTPUT_SIZE] = initial_row if at_valley else np.nan
    window[WINDOW_PREVIOUS] = initial_row[O.time]
    window[WINDOW_PREVIOUS + 1:] = initial_row[list(INTEGRATED_COLUMNS)]
    _start_maxima(window, initial_row)
    return window


@kernel
def _start_maxima(window, row):
    """The window's maxima start with the values of its opening row."""
    window[WINDOW_ACCUMULATORS + ACC_MAX_TILT] = abs(row[O.vane_tilt])
    for region in range(REGION_COUNT):
        window[WINDOW_ACCUMULATORS + ACC_MAX_FORCE + region] = row[O.normal_force + region]


@kernel
def accumulate(window, run_dwell, out):
    """Add the accepted step ending at row `out` to the window: trapezoidal integrals of the INTEGRATED_COLUMNS,
    maxima, and its length to the dwell of the mode at its end (the same rule for the run-long dwell)."""
    acc = WINDOW_ACCUMULATORS
    previous_time = window[WINDOW_PREVIOUS]
    time = out[O.time]
    if math.isfinite(previous_time):
        step = time - previous_time
        for k in range(INTEGRALS):
            window[acc + k] += 0.5 * step * (window[WINDOW_PREVIOUS + 1 + k] + out[INTEGRATED_COLUMNS[k]])
        key = mode_key(out)
        window[acc + ACC_DWELL + key] += step
        run_dwell[key] += step
    window[WINDOW_PREVIOUS] = time
    for k in range(INTEGRALS):
        window[WINDOW_PREVIOUS + 1 + k] = out[INTEGRATED_COLUMNS[k]]
    window[acc + ACC_MAX_TILT] = max(window[acc + ACC_MAX_TILT], abs(out[O.vane_tilt]))
    window[acc + ACC_LAW_EXCESS] = max(window[acc + ACC_LAW_EXCESS], out[O.contact_law_excess])
    for region in range(REGION_COUNT):
        window[acc + ACC_MAX_FORCE + region] = max(window[acc + ACC_MAX_FORCE + region],
                                                   out[O.normal_force + region])


@kernel
def close_window(window, out, lobe_index, records, count):
    """Write the lobe record of the window ending at row `out` (a valley) into records[count] and open the next
    window there. Returns the new record count (records is never overrun: the loop stops when it is full)."""
    records[count, RECORD_LOBE] = lobe_index
    for i in range(OUTPUT_SIZE):
        records[count, RECORD_START + i] = window[WINDOW_START + i]
        records[count, RECORD_END + i] = out[i]
        window[WINDOW_START + i] = out[i]
    for i in range(ACCUMULATOR_SIZE):
        records[count, RECORD_ACCUMULATORS + i] = window[WINDOW_ACCUMULATORS + i]
        window[WINDOW_ACCUMULATORS + i] = 0.0
    _start_maxima(window, out)
    return count + 1
