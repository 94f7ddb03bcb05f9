"""The time loop: one step loop for every method, the adaptive Dormand-Prince 5(4) pair and the thesis's ABM4 PECE
with RK4 start (docs/model.md §8.2).

`advance` is entered once per advance and runs until the end time, a full output buffer or a failure. It owns
what every method shares, written once: events (valley crossing, end of the speed ramp, the end time) clip the step
to land on them, and so do contact onsets and separations (a step that changes a contact is redone to end at the
located change); a step is rejected when its error is too large or the state is invalid; after an accepted step
the memory (warm start, impact velocities, mode, lobe) is updated, the output row recorded, the lobe window
accumulated (mechanics.loop.windows) and,
at a valley, the lobe record written and the chambers switched. A method is a set of kernels with one signature
each (begin, bounded step, attempt, after rejection, after acceptance: the block "The methods" below):
`dopri5_*` from the tableau below (as scipy's RungeKutta classes do), `abm4_*` as Adams-Bashforth predictor and
Adams-Moulton corrector with Runge-Kutta (RK4) steps to start and to land on events. The loop reaches them through
the `method_*` dispatchers, so it reads the same for every method and a new method does not edit it.
"""
import math

import numpy as np

from ...kernels.kernel import copy_values, kernel
from ...thermo.chamber_model import CHAMBER_STATES, gas_tolerance, switch_chambers
from ...thermo.property_table import table_from_arrays
from ...thermo.real_gas_nozzle import nozzle_table_from_arrays

from ..geometry.chamber_geometry import SectorTable
from .ark548_tableau import ARK_B, ARK_C, ARK_E, ARK_EXPLICIT, ARK_GAMMA, ARK_IMPLICIT, ARK_STAGES
from .dynamics import KernelContext, chamber_inputs_at, chamber_rates_at, evaluate, evaluate_with_inputs
from .layout import (ANGLE, ANGULAR_VELOCITY, GAS_BLOCK, GAS_STATE_INVALID, MEM_CLOSEST_OFFSET, MEM_LAW_EXCESS,
                     MEM_LOBE_COUNT, MEM_LOBE_START, MEM_MODE, MEM_ONSET_VELOCITY, NOT_FINITE, REACHED_END,
                     RECORD_FULL, STEP_TOO_SMALL, VX, VY, WORK_IN, WORK_LIMIT, X, Y)
from .machine import ABM4, ARK548, REAL_GAS_MODEL
from .outputs import O
from ..contact.regions import MEMORY_SLOTS, REGION_COUNT, REGION_MEMORY_SLOT
from .speed import ramp_end_time, rotor_motion, time_of_angle
from .windows import accumulate, close_window

# counters shared with Python
# (NEWTON_ITERATIONS: chamber-rate evaluations of the implicit stages' Newton iterations, JACOBIANS: finite-difference
# Jacobians of the chamber rates, both of ark548)
(ACCEPTED, REJECTED, EVALUATIONS, VALLEY_CROSSINGS, MODE_CHANGES, RESTARTS, EVENT_RETRIES, NEWTON_ITERATIONS,
 JACOBIANS) = range(9)
COUNTER_SIZE = 9
# control values kept between advances (CONTROL_STIFFNESS: DOPRI5's estimate of the dominant eigenvalue's modulus
# at the last attempted step [1/s], the larger of the stages' (_dopri5_stiffness) and the chamber Jacobian's
# (_chamber_spectral_radius), 0 when there is none)
CONTROL_STEP, CONTROL_HISTORY, CONTROL_SMALL_ERRORS, CONTROL_PREVIOUS_ERROR, CONTROL_STIFFNESS = range(5)
CONTROL_SIZE = 5
# step-grid replay (docs/model.md §8.2): grid_counts holds the number of step end times to follow, the index of the
# next one, the number recorded by this advance and whether the replay fell back to adaptive steps
GRID_FOLLOW, GRID_NEXT, GRID_RECORDED, GRID_FELL_BACK = range(4)
GRID_COUNTS_SIZE = 4
# the columns of a recorded grid: each step's start, size, end and whether it was redone to land on a contact change
GRID_START, GRID_STEP, GRID_END, GRID_REDONE = range(4)
GRID_COLUMNS = 4
REPLAY_ERROR_LIMIT = 10.0           # a replayed step whose scaled error exceeds this ends the replay
PI_BETA = 0.04                      # Hairer's DOPRI5 step-size stabilisation
POWER_ITERATIONS = 12                # of the chamber Jacobian for its dominant eigenvalue (_chamber_spectral_radius)
STABILITY_LIMIT = 2.5               # DOPRI5's proposed step keeps h rho below this (real-axis boundary 3.31;
#                                     the margin measured, docs/model.md §8.2: 3.0 left jumps in the step map)
RK4_GROWTH = 5.0                    # the most an ABM4 start (RK4) step grows h by (_abm4_start_growth)
ABM_HISTORY = 7                     # points kept at the current spacing (step doubling reuses every second one)
NO_EVENT, END_EVENT, RAMP_EVENT, VALLEY_EVENT, CONTACT_EVENT = range(5)
NO_SLOT = -1                        # no contact change to redo the step to (_contact_changes)
ROOT_SAMPLES = 8                    # sign samples of the penetration's cubic before bisection (_penetration_root)
TIME_RESOLUTION = 16.0 * np.finfo(np.float64).eps      # the smallest step relative to the time (smallest_step)

# Dormand-Prince 5(4) (Hairer, Norsett, Wanner, Solving ODEs I, Table 5.2): nodes C, coefficients A (the last row
# is the 5th-order solution B: first same as last), error weights E = B - B_hat.
DOPRI5_C = np.array([0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0])
DOPRI5_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0]])
DOPRI5_E = np.array([71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
                     -1.0 / 40.0])
# classical RK4 (thesis Table 4.1), the start and event steps of ABM4
RK4_C = np.array([0.0, 0.5, 0.5, 1.0])
RK4_A = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 1.0]])
RK4_B = np.array([1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0])

# workspace rows (each as long as the state vector): the stages k_1 .. k_7 of DOPRI5 (RK4 uses the first four; row
# 0 is f at the current point), then the stage point, the new state, the ABM4 predictor and its derivative
STAGES = 7
W_STAGE, W_Y_NEW, W_Y_PREDICTED, W_F_PREDICTED = range(STAGES, STAGES + 4)
WORKSPACE_ROWS = STAGES + 4
# ARK5(4)8L[2]SA: the workspace row of each stage's derivative (the 8th in ABM4's predictor row), the row of the chamber
# rates and Newton updates of an implicit stage (ABM4's predicted derivative); its matrices live in ABM4's history
# rows: the LU factors of I - h gamma J and their pivots, the chamber-rate Jacobian J (its base rates and whether it
# is current after it), the known part of the implicit stage
ARK_ROWS = np.array([0, 1, 2, 3, 4, 5, 6, W_Y_PREDICTED])
W_NEWTON = W_F_PREDICTED
H_LU, H_JACOBIAN, H_KNOWN = range(3)
JACOBIAN_CURRENT = CHAMBER_STATES * (CHAMBER_STATES + 1)   # in row H_JACOBIAN: 1 while J may be reused, else 0
NEWTON_TOLERANCE = 1e-2      # a stage's Newton iteration has converged when its predicted remaining error is below
#                              this times the tolerance (RMS)
NEWTON_RATE = CHAMBER_STATES  # in row H_KNOWN: the Newton iteration's last eta = theta/(1 - theta) (0: none yet)
NEWTON_ITERATION_LIMIT = 6
NEWTON_SLOW = 3              # a stage that needs this many iterations has J formed again for the next step
NEWTON_FAILED = 1e3          # the scaled error of a step whose Newton iteration did not converge (shrinks it 3.6x)


@kernel
def _tolerance(i, value, m, c):
    """atol_i + rtol |y_i| with the absolute tolerances of docs/model.md §8.2 (chamber states: thermo's); the work
    integrals, running sums, atol_work alone (§8.2: rtol times the sum would loosen them as the run goes on)."""
    if i >= GAS_BLOCK:
        return gas_tolerance(i - GAS_BLOCK, value, c, m.relative_tolerance)
    if i == X or i == Y:
        atol = m.atol_position
    elif i == ANGLE:
        atol = m.atol_angle
    elif i == VX or i == VY:
        atol = m.atol_velocity
    elif i == ANGULAR_VELOCITY:
        atol = m.atol_angular_velocity
    else:
        return m.atol_work
    return atol + m.relative_tolerance * abs(value)


@kernel
def _all_finite(values, count):
    for i in range(count):
        if not math.isfinite(values[i]):
            return False
    return True


@kernel
def _clip_to_events(t, step, t_end, law, memory, m, contact_time):
    """Shorten the step to land on the next event inside it (contact_time: a located contact onset or separation,
    inf if none); return (step, event kind)."""
    event = NO_EVENT
    if t + step >= t_end:
        step = t_end - t
        event = END_EVENT
    ramp_end = ramp_end_time(law)
    if t < ramp_end < t + step:
        step = ramp_end - t
        event = RAMP_EVENT
    next_valley = memory[MEM_LOBE_START] + 2.0 * math.pi / m.lobes
    if rotor_motion(t + step, law)[0] >= next_valley:
        step = time_of_angle(next_valley, t, t + step, law) - t
        event = VALLEY_EVENT
    if contact_time < t + step:
        step = contact_time - t
        event = CONTACT_EVENT
    return step, event


@kernel
def _slot_gap(row, slot):
    """(penetration, its rate) of a memory slot in an output row: the deepest of the regions sharing the slot (c5/c6
    are one tip contact, docs/model.md §5.1); NaN if no region of the slot has a candidate."""
    gap = math.nan
    rate = math.nan
    for region in range(REGION_COUNT):
        delta = row[O.penetration + region]
        if REGION_MEMORY_SLOT[region] == slot and math.isfinite(delta) and not delta <= gap:
            gap = delta
            rate = row[O.penetration_rate + region]
    return gap, rate


@kernel
def _penetration_root(start, start_rate, end, end_rate, step):
    """The earliest s in (0, 1] where the cubic Hermite p(s) through (start, step start_rate) at s = 0 and (end,
    step end_rate) at s = 1 changes sign from that of `start` (their signs differ): ROOT_SAMPLES sign samples, then
    bisection to the resolution of s (docs/model.md §8.2, events)."""
    closed = start > 0.0
    low = 0.0
    high = 1.0
    for k in range(1, ROOT_SAMPLES + 1):
        high = k / ROOT_SAMPLES
        if (_hermite(high, start, start_rate, end, end_rate, step) > 0.0) != closed:
            break
        low = high
    while high - low > 4.0 * np.finfo(np.float64).eps:
        middle = 0.5 * (low + high)
        if (_hermite(middle, start, start_rate, end, end_rate, step) > 0.0) != closed:
            high = middle
        else:
            low = middle
    return high


@kernel
def _hermite(s, start, start_rate, end, end_rate, step):
    """The cubic Hermite interpolant at s in [0, 1] of values start, end and slopes start_rate, end_rate (per unit
    time) over a step of length `step`."""
    s2 = s * s
    s3 = s2 * s
    return ((2.0 * s3 - 3.0 * s2 + 1.0) * start + (s3 - 2.0 * s2 + s) * step * start_rate
            + (-2.0 * s3 + 3.0 * s2) * end + (s3 - s2) * step * end_rate)


@kernel
def _contact_changes(start_row, end_row, memory, step, landed, resolution):
    """(s, slot, at_end): the earliest contact onset or separation inside the step to redo the step to, as a fraction
    s of it and its memory slot (inf, NO_SLOT if none), and the bit mask of the slots whose change is taken at the
    step end (docs/model.md §8.2, events). A slot changes when its penetration's sign at the step end differs from
    its memory (closed: a stored impact velocity) and from its sign at the step start; the time of delta = 0 is the
    root of the cubic Hermite through delta and its rate at both ends. A root within `resolution` (a fraction of
    the step) of either end is taken at the step end: no contact change makes a step shorter than h_min. The slots
    in the mask `landed` (the step ended on their located change) are not tested again: their delta there is 0 up
    to round-off, of either sign. A change whose start and end signs agree (a landing undone at once, or a slot
    without a candidate at the start) is not located: it is taken at the step end by _update_memory."""
    earliest = math.inf
    earliest_slot = NO_SLOT
    at_end = 0
    for slot in range(MEMORY_SLOTS):
        if landed & (1 << slot):
            continue
        end, end_rate = _slot_gap(end_row, slot)
        touching = end > 0.0
        if touching == (memory[MEM_ONSET_VELOCITY + slot] > 0.0):
            continue
        start, start_rate = _slot_gap(start_row, slot)
        if (start > 0.0) == touching or not (math.isfinite(start_rate) and math.isfinite(end_rate)):
            continue
        s = _penetration_root(start, start_rate, end, end_rate, step)
        if s <= resolution or s >= 1.0 - resolution:
            at_end |= 1 << slot
        elif s < earliest:
            earliest = s
            earliest_slot = slot
    return earliest, earliest_slot, at_end


@kernel
def _update_memory(out, memory, m, landed):
    """Update the memory after an accepted step (docs/model.md §5.1, §8.1); return True if the contact mode changed.
    The slots in the bit mask `landed` (the step ended on their located change) open or close: at an onset
    delta_dot^- = max(|delta_dot|, v_floor) at the event, at a separation it is cleared. Any other slot whose contact
    changed without a located event (_contact_changes) is updated from the step end the same way."""
    memory[MEM_CLOSEST_OFFSET] = out[O.closest_parameter_offset]
    for slot in range(MEMORY_SLOTS):
        gap, rate = _slot_gap(out, slot)
        index = MEM_ONSET_VELOCITY + slot
        closed = memory[index] > 0.0
        if landed & (1 << slot):
            touching = not closed
        else:
            touching = gap > 0.0
        if not touching:
            memory[index] = 0.0
        elif not closed:
            memory[index] = max(abs(rate), m.onset_velocity_floor) if math.isfinite(rate) else m.onset_velocity_floor
    memory[MEM_LAW_EXCESS] = max(memory[MEM_LAW_EXCESS], out[O.contact_law_excess])
    changed = out[O.contact_mode] != memory[MEM_MODE]
    memory[MEM_MODE] = out[O.contact_mode]
    return changed


@kernel
def _stage_point(target, y, h, tableau, row, k, count, n):
    """target = y + h sum_j tableau[row, j] k_j over the first `count` stages (k: the workspace, one row a stage)."""
    for i in range(n):
        total = 0.0
        for j in range(count):
            total += tableau[row, j] * k[j, i]
        target[i] = y[i] + h * total


# The methods (docs/model.md §8.2). Each is a set of kernels with the same arguments:
#   <method>_begin(control, history, work, n)                 at the start of an advance
#   <method>_bounded_step(h, m)                               the step to try before the events clip it
#   <method>_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters)
#                                                             one step: new state in work[W_Y_NEW], its derivative in
#                                                             work[STAGES - 1], its output row in `out`; returns
#                                                             (failure status, scaled error: <= 1 accepts)
#   <method>_after_rejection(control, step, err, finite)      the step size to retry with
#   <method>_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters)
#                                                             the method's memory and the next step size
# The step size and the method's memory live in `control` (CONTROL_*), so an advance continues where the last
# ended. The `method_*` dispatchers at the end of this block are the only place that names the methods: a new
# method is its kernels and one line in each dispatcher; the loop (`advance`) is the same for every method.

@kernel
def _dopri5_stiffness(rate_squares, state_squares):
    """rho = ||k_7 - k_6|| / ||y_n+1 - Y_6|| over the states that feed back (vane, chambers; not the quadratures),
    the modulus of the dominant eigenvalue of the Jacobian along the step (docs/model.md §8.2, the stability cap):
    stages 6 and 7 are both at t + h (c_6 = c_7 = 1), so their difference is f(y_n+1) - f(Y_6) ~ J (y_n+1 - Y_6)
    [Hairer-Wanner, Solving ODEs II, §IV.2; dopri5.f's stiffness detection], in the error norm's scaling. 0 (no
    estimate) when the two points coincide or the stages are not finite."""
    if not (state_squares > 0.0 and rate_squares < math.inf):
        return 0.0
    rho = math.sqrt(rate_squares / state_squares)
    return rho if rho < math.inf else 0.0


@kernel
def _chamber_product(history, x0, x1, x2, x3):
    """J x for the chamber-rate Jacobian J in history row H_JACOBIAN (row-major, _chamber_jacobian), as 4 values."""
    row = history[H_JACOBIAN]
    return (row[0] * x0 + row[1] * x1 + row[2] * x2 + row[3] * x3,
            row[4] * x0 + row[5] * x1 + row[6] * x2 + row[7] * x3,
            row[8] * x0 + row[9] * x1 + row[10] * x2 + row[11] * x3,
            row[12] * x0 + row[13] * x1 + row[14] * x2 + row[15] * x3)


@kernel
def _chamber_spectral_radius(history, y, m, c):
    """The modulus of the dominant eigenvalue of the chamber-rate Jacobian J in history row H_JACOBIAN [1/s]
    (docs/model.md §8.2, the stability cap): POWER_ITERATIONS normalised products from the tolerance vector s, then
    rho = (|J^2 x| / |x|)^(1/2) in the error norm's scaling (a complex dominant pair gives no limit of |J x| / |x|,
    but the square's ratio is its modulus squared). 0 when J is not finite or J x vanishes."""
    s0 = _tolerance(GAS_BLOCK, y[GAS_BLOCK], m, c)
    s1 = _tolerance(GAS_BLOCK + 1, y[GAS_BLOCK + 1], m, c)
    s2 = _tolerance(GAS_BLOCK + 2, y[GAS_BLOCK + 2], m, c)
    s3 = _tolerance(GAS_BLOCK + 3, y[GAS_BLOCK + 3], m, c)
    x0, x1, x2, x3 = s0, s1, s2, s3
    for _ in range(POWER_ITERATIONS):
        z0, z1, z2, z3 = _chamber_product(history, x0, x1, x2, x3)
        largest = max(abs(z0 / s0), abs(z1 / s1), abs(z2 / s2), abs(z3 / s3))
        if not (0.0 < largest < math.inf):
            return 0.0
        x0, x1, x2, x3 = z0 / largest, z1 / largest, z2 / largest, z3 / largest
    z0, z1, z2, z3 = _chamber_product(history, x0, x1, x2, x3)
    w0, w1, w2, w3 = _chamber_product(history, z0, z1, z2, z3)
    before = (x0 / s0) ** 2 + (x1 / s1) ** 2 + (x2 / s2) ** 2 + (x3 / s3) ** 2
    after = (w0 / s0) ** 2 + (w1 / s1) ** 2 + (w2 / s2) ** 2 + (w3 / s3) ** 2
    rho = math.sqrt(math.sqrt(after / before))
    return rho if rho < math.inf else 0.0


@kernel
def _stability_capped(h, control):
    """The proposed step kept inside DOPRI5's stability region: h rho <= STABILITY_LIMIT (docs/model.md §8.2). A
    continuous function of the state where rho is, so it adds no discrete decision; it only proposes steps."""
    rho = control[CONTROL_STIFFNESS]
    if rho > 0.0:
        return min(h, STABILITY_LIMIT / rho)
    return h


@kernel
def _error_after_rejection(step, err, finite):
    """Shrink by the error's own factor (at most 5x) if the error rejected the step, else halve."""
    if err > 1.0 and finite:
        return step * max(0.2, 0.9 * err ** -(0.2 - 0.75 * PI_BETA))
    return 0.5 * step


@kernel
def _pi_after_acceptance(control, step, err, event, rejected_last):
    """PI control: h_new = step min(10, max(0.2, 0.9 err^-(0.2 - 0.75 beta) err_prev^beta)), no growth right after a
    rejection; a step shortened by an event does not shrink the step size."""
    err = max(err, 1e-10)
    factor = min(10.0, max(0.2, 0.9 * err ** -(0.2 - 0.75 * PI_BETA) * control[CONTROL_PREVIOUS_ERROR] ** PI_BETA))
    if rejected_last:
        factor = min(factor, 1.0)
    control[CONTROL_PREVIOUS_ERROR] = max(err, 1e-4)
    h = control[CONTROL_STEP]
    control[CONTROL_STEP] = max(h, step * factor) if event != NO_EVENT else step * factor


@kernel
def dopri5_begin(control, history, work, n):
    """The PI controller's previous error starts at 1e-4 (Hairer's DOPRI5)."""
    if control[CONTROL_PREVIOUS_ERROR] <= 0.0:
        control[CONTROL_PREVIOUS_ERROR] = 1e-4


@kernel
def dopri5_bounded_step(h, m):
    return min(h, m.max_step)


@kernel
def dopri5_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters):
    """One Dormand-Prince step from (t, y) with k_1 = work[0] (first same as last: k_7 is the new state's
    derivative, work[STAGES - 1]). Returns (failure status, RMS scaled error)."""
    m = ctx.machine[0]
    c = ctx.chambers[0]
    n = y.size
    failure = 0
    for i in range(1, STAGES - 1):
        _stage_point(work_rows[W_STAGE], y, h, DOPRI5_A, i, work, i, n)
        failure |= evaluate(t + DOPRI5_C[i] * h, work_rows[W_STAGE], ctx, memory, work_rows[i], out, False)
    last = STAGES - 1                       # the new state (c_7 = 1), its rates and output row
    _stage_point(work_rows[W_Y_NEW], y, h, DOPRI5_A, last, work, last, n)
    end_status, end_inputs = evaluate_with_inputs(t + DOPRI5_C[last] * h, work_rows[W_Y_NEW], ctx, memory,
                                                  work_rows[last], out, True)
    failure |= end_status
    counters[EVALUATIONS] += STAGES - 1
    squares = 0.0
    rate_squares = 0.0
    state_squares = 0.0
    for i in range(n):
        error = 0.0
        for j in range(STAGES):
            error += DOPRI5_E[j] * work[j, i]
        scale = _tolerance(i, max(abs(y[i]), abs(work[W_Y_NEW, i])), m, c)
        squares += (h * error / scale) ** 2
        if i < WORK_IN or GAS_BLOCK <= i < GAS_BLOCK + CHAMBER_STATES:     # the states that feed back
            rate_squares += ((work[STAGES - 1, i] - work[STAGES - 2, i]) / scale) ** 2
            state_squares += ((work[W_Y_NEW, i] - work[W_STAGE, i]) / scale) ** 2
    # the cap is for the chambers' pressure relaxation: under the pressure tables (no chamber states) there is none
    control[CONTROL_STIFFNESS] = 0.0
    if n > GAS_BLOCK:
        # the stages' estimate is a lower bound (it measures J along y_n+1 - Y_6, where the stiff mode is damped);
        # the chamber Jacobian at the new state gives the chambers' dominant eigenvalue itself
        rho = _dopri5_stiffness(rate_squares, state_squares)
        # at the new state: its chamber geometry and chamber rates are those of the last stage's evaluation
        end_gas_status = GAS_STATE_INVALID if end_status == GAS_STATE_INVALID else 0
        if _chamber_jacobian_around(t + h, work_rows[W_Y_NEW], end_inputs, work_rows[last], end_gas_status, ctx,
                                    history, work_rows, counters) == 0:
            rho = max(rho, _chamber_spectral_radius(history, work_rows[W_Y_NEW], m, c))
        control[CONTROL_STIFFNESS] = rho
    return failure, math.sqrt(squares / n)


@kernel
def dopri5_after_rejection(control, step, err, finite):
    """The error's shrink (_error_after_rejection), kept inside the stability region (_stability_capped)."""
    return _stability_capped(_error_after_rejection(step, err, finite), control)


@kernel
def dopri5_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters):
    """The PI control's next step (_pi_after_acceptance), kept inside the stability region (_stability_capped)."""
    _pi_after_acceptance(control, step, err, event, rejected_last)
    control[CONTROL_STEP] = _stability_capped(control[CONTROL_STEP], control)


@kernel
def abm4_begin(control, history, work, n):
    """f_n of the current point is the newest history point."""
    for i in range(n):
        history[0, i] = work[0, i]
    control[CONTROL_HISTORY] = max(control[CONTROL_HISTORY], 1.0)


@kernel
def abm4_bounded_step(h, m):
    """ABM4 keeps its step (h_max bounds only its doubling): the history is at that spacing."""
    return h


@kernel
def _abm4_multistep(control, event):
    """True if the step is a PECE step (four points at the current spacing, no event), False for an RK4 step."""
    return control[CONTROL_HISTORY] >= 4.0 and event == NO_EVENT


@kernel
def abm4_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters):
    """One ABM4 PECE step from (t, y) (docs/model.md §8.2), f_n = history[0] = work[0]:
      AB4:  y^p = y_n + h/24 (55 f_n - 59 f_n-1 + 37 f_n-2 - 9 f_n-3);  AM4: y^c = y_n + h/24 (9 f^p + 19 f_n - 5 f_n-1 + f_n-2)
      LTE ~ 19/270 (y^c - y^p);
    or, without four points at the current spacing or when the step lands on an event, one RK4 step. Returns (failure status, max scaled error).
    The RK4 step's error is that of the embedded 3rd-order solution (b^ = 1/6, 1/3, 1/3, 0, 1/6 on k_1..k_4 and
    f(t + h, y_new), which the step evaluates anyway): h/6 (k_4 - f(t + h, y_new)) (docs/model.md §8.2)."""
    m = ctx.machine[0]
    c = ctx.chambers[0]
    n = y.size
    y_new = work_rows[W_Y_NEW]
    failure = 0
    worst = 0.0
    if _abm4_multistep(control, event):
        y_pred = work_rows[W_Y_PREDICTED]
        f_pred = work_rows[W_F_PREDICTED]
        for i in range(n):
            y_pred[i] = y[i] + h / 24.0 * (55.0 * history[0, i] - 59.0 * history[1, i] + 37.0 * history[2, i]
                                           - 9.0 * history[3, i])
        failure |= evaluate(t + h, y_pred, ctx, memory, f_pred, out, False)
        for i in range(n):
            y_new[i] = y[i] + h / 24.0 * (9.0 * f_pred[i] + 19.0 * history[0, i] - 5.0 * history[1, i]
                                          + history[2, i])
            worst = max(worst, abs(19.0 / 270.0 * (y_new[i] - y_pred[i])) / _tolerance(i, y_new[i], m, c))
        counters[EVALUATIONS] += 2
    else:
        for i in range(1, 4):
            _stage_point(work_rows[W_STAGE], y, h, RK4_A, i, work, i, n)
            failure |= evaluate(t + RK4_C[i] * h, work_rows[W_STAGE], ctx, memory, work_rows[i], out, False)
        for i in range(n):
            y_new[i] = y[i] + h * (RK4_B[0] * work[0, i] + RK4_B[1] * work[1, i] + RK4_B[2] * work[2, i]
                                   + RK4_B[3] * work[3, i])
        counters[EVALUATIONS] += 4
    failure |= evaluate(t + h, y_new, ctx, memory, work_rows[STAGES - 1], out, True)
    if not _abm4_multistep(control, event):
        for i in range(n):
            worst = max(worst, abs(h / 6.0 * (work[3, i] - work[STAGES - 1, i])) / _tolerance(i, y_new[i], m, c))
    return failure, worst


@kernel
def abm4_after_rejection(control, step, err, finite):
    """Halve (or shrink by the error's own factor, at most 5x) and restart from y_n."""
    control[CONTROL_HISTORY] = 1.0
    control[CONTROL_SMALL_ERRORS] = 0.0
    factor = max(0.2, min(0.5, 0.9 * err ** -0.25)) if (err > 1.0 and finite) else 0.5
    return factor * min(control[CONTROL_STEP], step)


@kernel
def _abm4_shift_history(control, event, history, work, n):
    """The accepted point becomes f_n; the older points shift back unless an event restarted the spacing."""
    valid = int(control[CONTROL_HISTORY])
    if event == NO_EVENT:
        for j in range(ABM_HISTORY - 1, 0, -1):
            for i in range(n):
                history[j, i] = history[j - 1, i]
        valid = min(valid + 1, ABM_HISTORY)
    else:
        valid = 1
    for i in range(n):
        history[0, i] = work[0, i]
    control[CONTROL_HISTORY] = valid


@kernel
def abm4_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters):
    """Shift the history (restart it after a non-smooth point); double h after 8 PECE steps with err < 1/50 if
    2h <= h_max, reusing every second point when 7 are known at the current spacing, else restarting. After an RK4
    step the step grows by its own error (_abm4_start_growth)."""
    multistep = _abm4_multistep(control, event)
    _abm4_shift_history(control, event, history, work, n)
    if restart:
        control[CONTROL_HISTORY] = 1.0
        counters[RESTARTS] += 1
    if not multistep:
        _abm4_start_growth(control, step, err, rejected_last, m)
        return
    small_errors = control[CONTROL_SMALL_ERRORS] + 1.0 if (multistep and err < 1.0 / 50.0) else 0.0
    h = control[CONTROL_STEP]
    if small_errors >= 8.0 and 2.0 * h <= m.max_step:
        if control[CONTROL_HISTORY] >= ABM_HISTORY:
            for j in range(1, 4):
                for i in range(n):
                    history[j, i] = history[2 * j, i]
            control[CONTROL_HISTORY] = 4.0
        else:
            control[CONTROL_HISTORY] = 1.0
        control[CONTROL_STEP] = 2.0 * h
        small_errors = 0.0
    control[CONTROL_SMALL_ERRORS] = small_errors


@kernel
def _abm4_start_growth(control, step, err, rejected_last, m):
    """After an RK4 step: if its error allows at least twice the step (0.9 err^(-1/4) >= 2, not right after a
    rejection), grow h by that factor, at most RK4_GROWTH and to h_max, and restart the history at the new spacing;
    a step shortened by an event never shrinks h. So after a step collapse (a rejection halves h, and PECE alone
    doubles only after 8 quiet steps, which every contact change restarts) the RK4 steps bring h back to what their
    error allows, as DOPRI5's controller does (docs/model.md §8.2)."""
    factor = min(RK4_GROWTH, 0.9 * max(err, 1e-10) ** -0.25)
    if rejected_last or factor < 2.0:
        return
    h = control[CONTROL_STEP]
    grown = min(max(h, step * factor), m.max_step)
    if grown >= 2.0 * h:
        control[CONTROL_STEP] = grown
        control[CONTROL_HISTORY] = 1.0
        control[CONTROL_SMALL_ERRORS] = 0.0


@kernel
def _chamber_jacobian(t, y, ctx, memory, history, work_rows, counters):
    """J_qp = d f_q/d y_p of the chamber rates in the chamber states (T_L, m_L, T_T, m_T) at (t, y), by forward
    differences at the chamber geometry of the pose in y (history row H_JACOBIAN, row-major, the base rates after
    it); returns the failure status (docs/model.md §8.2, ark548)."""
    inputs = chamber_inputs_at(t, y, ctx, memory)
    rates = work_rows[W_NEWTON]
    failure = chamber_rates_at(t, y, inputs, ctx, rates)[0]
    return _chamber_jacobian_around(t, y, inputs, rates, failure, ctx, history, work_rows, counters)


@kernel
def _chamber_jacobian_around(t, y, inputs, base, base_failure, ctx, history, work_rows, counters):
    """_chamber_jacobian from the chamber geometry `inputs` of (t, y) and the chamber rates there (`base`, from
    GAS_BLOCK, with their failure status `base_failure`)."""
    m = ctx.machine[0]
    c = ctx.chambers[0]
    perturbed = work_rows[W_STAGE]
    rates = work_rows[W_NEWTON]
    base_column = CHAMBER_STATES * CHAMBER_STATES      # the base rates, after J in the row
    copy_values(perturbed, 0, y, 0, y.size)
    failure = base_failure
    for q in range(CHAMBER_STATES):
        history[H_JACOBIAN, base_column + q] = base[GAS_BLOCK + q]
    for p in range(CHAMBER_STATES):
        i = GAS_BLOCK + p
        delta = math.sqrt(np.finfo(np.float64).eps) * max(abs(y[i]), 1e3 * _tolerance(i, 0.0, m, c))
        perturbed[i] = y[i] + delta
        failure |= chamber_rates_at(t, perturbed, inputs, ctx, rates)[0]
        perturbed[i] = y[i]
        for q in range(CHAMBER_STATES):
            history[H_JACOBIAN, CHAMBER_STATES * q + p] = ((rates[GAS_BLOCK + q] - history[H_JACOBIAN, base_column + q])
                                                           / delta)
    counters[JACOBIANS] += 1
    finite = True
    for k in range(JACOBIAN_CURRENT):
        finite = finite and math.isfinite(history[H_JACOBIAN, k])
    if failure != 0 or not finite:
        for k in range(JACOBIAN_CURRENT + 1):    # the history stays finite (a saved FMU state is checked for it)
            history[H_JACOBIAN, k] = 0.0
        return failure if failure != 0 else GAS_STATE_INVALID
    history[H_JACOBIAN, JACOBIAN_CURRENT] = 1.0
    return failure


@kernel
def _factor_iteration_matrix(history, h_gamma):
    """LU with partial pivoting of M = I - h gamma J (J in history row H_JACOBIAN) into history row H_LU, the
    pivots after the factors; False if M is singular."""
    p = CHAMBER_STATES
    for row in range(p):
        for col in range(p):
            history[H_LU, p * row + col] = (1.0 if row == col else 0.0) - h_gamma * history[H_JACOBIAN, p * row + col]
    for col in range(p):
        pivot = col
        for row in range(col + 1, p):
            if abs(history[H_LU, p * row + col]) > abs(history[H_LU, p * pivot + col]):
                pivot = row
        history[H_LU, p * p + col] = pivot
        if history[H_LU, p * pivot + col] == 0.0 or not math.isfinite(history[H_LU, p * pivot + col]):
            return False
        if pivot != col:
            for k in range(p):
                swap = history[H_LU, p * col + k]
                history[H_LU, p * col + k] = history[H_LU, p * pivot + k]
                history[H_LU, p * pivot + k] = swap
        for row in range(col + 1, p):
            factor = history[H_LU, p * row + col] / history[H_LU, p * col + col]
            history[H_LU, p * row + col] = factor
            for k in range(col + 1, p):
                history[H_LU, p * row + k] -= factor * history[H_LU, p * col + k]
    return True


@kernel
def _solve_iteration_matrix(history, values, start):
    """values[start:start + 4] = M^-1 values[start:start + 4] with the LU factors of _factor_iteration_matrix."""
    p = CHAMBER_STATES
    for col in range(p):
        pivot = int(history[H_LU, p * p + col])
        if pivot != col:
            swap = values[start + col]
            values[start + col] = values[start + pivot]
            values[start + pivot] = swap
    for col in range(p):
        for row in range(col + 1, p):
            values[start + row] -= history[H_LU, p * row + col] * values[start + col]
    for col in range(p - 1, -1, -1):
        for k in range(col + 1, p):
            values[start + col] -= history[H_LU, p * col + k] * values[start + k]
        values[start + col] /= history[H_LU, p * col + col]


@kernel
def _implicit_chamber_stage(t, stage, h_gamma, ctx, memory, history, work_rows, counters):
    """Solve Y_g = z_g + h gamma f_g(Y) for the chamber states g of the stage point `stage` (its other states set,
    its chamber states the predictor; z_g in history row H_KNOWN) by simplified Newton with the factored
    M = I - h gamma J, at the chamber geometry of the stage's pose, until the remaining error eta |update| (RMS,
    scaled by the tolerance; eta = theta/(1 - theta) from the contraction theta of the last two updates, or of the
    previous stage's iteration as eta_old^0.8 for the first update, Hairer-Wanner IV.8) is below NEWTON_TOLERANCE.
    Returns (failure status, converged); a divergence (theta >= 1) does not converge, and a slow convergence
    (NEWTON_SLOW iterations) marks J for forming again at the next step."""
    m = ctx.machine[0]
    c = ctx.chambers[0]
    inputs = chamber_inputs_at(t, stage, ctx, memory)
    update = work_rows[W_NEWTON]
    eta = max(history[H_KNOWN, NEWTON_RATE] if history[H_KNOWN, NEWTON_RATE] > 0.0 else 1.0, 1e-3) ** 0.8
    previous = math.inf
    for iteration in range(1, NEWTON_ITERATION_LIMIT + 1):
        if iteration == NEWTON_SLOW:
            history[H_JACOBIAN, JACOBIAN_CURRENT] = 0.0
        failure = chamber_rates_at(t, stage, inputs, ctx, update)[0]
        counters[NEWTON_ITERATIONS] += 1
        if failure != 0:
            return failure, False
        for q in range(CHAMBER_STATES):
            i = GAS_BLOCK + q
            update[i] = history[H_KNOWN, q] + h_gamma * update[i] - stage[i]
        _solve_iteration_matrix(history, update, GAS_BLOCK)
        squares = 0.0
        for q in range(CHAMBER_STATES):
            i = GAS_BLOCK + q
            stage[i] += update[i]
            squares += (update[i] / _tolerance(i, stage[i], m, c)) ** 2
        norm = math.sqrt(squares / CHAMBER_STATES)
        if not math.isfinite(norm):
            return 0, False
        if iteration > 1:
            theta = norm / previous
            if theta >= 1.0:
                history[H_JACOBIAN, JACOBIAN_CURRENT] = 0.0
                return 0, False
            eta = theta / (1.0 - theta)
        if eta * norm <= NEWTON_TOLERANCE:
            history[H_KNOWN, NEWTON_RATE] = eta
            return 0, True
        previous = norm
    return 0, False


@kernel
def ark548_begin(control, history, work, n):
    """The step control is DOPRI5's."""
    dopri5_begin(control, history, work, n)


@kernel
def ark548_bounded_step(h, m):
    return dopri5_bounded_step(h, m)


@kernel
def ark548_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters):
    """One step of the additive Runge-Kutta pair ARK5(4)8L[2]SA (docs/model.md §8.2) from (t, y), k_1 = work[0]:
    every state but the chamber states (T_L, m_L, T_T, m_T) by the explicit tableau, the chamber states by the
    ESDIRK tableau, with the same nodes and weights. The stage's vane states are explicit, so each implicit stage
    is a 4-unknown solve at a known pose (_implicit_chamber_stage, predictor z + h gamma k_(i-1)); the Jacobian of
    the chamber rates is formed at (t, y) when it is not current (the first step, after a Newton failure, a slow
    convergence or a valley crossing) and M = I - h gamma J factored once per attempt. The cumulative gas states
    feed back on nothing: their stage values are not read. Under the pressure tables (no chamber states) it is
    the explicit tableau alone. The new state's derivative and output row take one more right-hand side (the
    explicit tableau is not first-same-as-last). Returns (failure status, RMS scaled error of the embedded
    4th-order solution; NEWTON_FAILED if a stage did not converge)."""
    m = ctx.machine[0]
    c = ctx.chambers[0]
    n = y.size
    implicit = n > GAS_BLOCK
    h_gamma = h * ARK_GAMMA
    failure = 0
    if implicit:
        if history[H_JACOBIAN, JACOBIAN_CURRENT] == 0.0:
            failure = _chamber_jacobian(t, y, ctx, memory, history, work_rows, counters)
        if failure != 0 or not _factor_iteration_matrix(history, h_gamma):
            history[H_JACOBIAN, JACOBIAN_CURRENT] = 0.0
            return failure, NEWTON_FAILED
    stage = work_rows[W_STAGE]
    for i in range(1, ARK_STAGES):
        for k in range(n):
            total = 0.0
            for j in range(i):
                total += (ARK_EXPLICIT[i, j] if k < GAS_BLOCK else ARK_IMPLICIT[i, j]) * work[ARK_ROWS[j], k]
            stage[k] = y[k] + h * total
        if implicit:
            for q in range(CHAMBER_STATES):
                history[H_KNOWN, q] = stage[GAS_BLOCK + q]
                stage[GAS_BLOCK + q] += h_gamma * work[ARK_ROWS[i - 1], GAS_BLOCK + q]
            status, converged = _implicit_chamber_stage(t + ARK_C[i] * h, stage, h_gamma, ctx, memory, history,
                                                        work_rows, counters)
            if status != 0 or not converged:
                history[H_JACOBIAN, JACOBIAN_CURRENT] = 0.0
                counters[EVALUATIONS] += i - 1
                return status, NEWTON_FAILED
        failure |= evaluate(t + ARK_C[i] * h, stage, ctx, memory, work_rows[ARK_ROWS[i]], out, False)
    y_new = work_rows[W_Y_NEW]
    squares = 0.0
    for k in range(n):
        increment = 0.0
        error = 0.0
        for j in range(ARK_STAGES):
            increment += ARK_B[j] * work[ARK_ROWS[j], k]
            error += ARK_E[j] * work[ARK_ROWS[j], k]
        y_new[k] = y[k] + h * increment
        squares += (h * error / _tolerance(k, max(abs(y[k]), abs(y_new[k])), m, c)) ** 2
    failure |= evaluate(t + h, y_new, ctx, memory, work_rows[STAGES - 1], out, True)
    counters[EVALUATIONS] += ARK_STAGES
    return failure, math.sqrt(squares / n)


@kernel
def ark548_after_rejection(control, step, err, finite):
    """DOPRI5's shrink without its stability cap (the stiff chamber states are implicit)."""
    return _error_after_rejection(step, err, finite)


@kernel
def ark548_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters):
    """DOPRI5's PI control without its stability cap (the stiff chamber states are implicit); the chambers
    switched at a valley: J is formed again."""
    if event == VALLEY_EVENT and n > GAS_BLOCK:
        history[H_JACOBIAN, JACOBIAN_CURRENT] = 0.0
    _pi_after_acceptance(control, step, err, event, rejected_last)



@kernel(inline=True)
def method_begin(code, control, history, work, n):
    if code == ABM4:
        abm4_begin(control, history, work, n)
    elif code == ARK548:
        ark548_begin(control, history, work, n)
    else:
        dopri5_begin(control, history, work, n)


@kernel(inline=True)
def method_bounded_step(code, h, m):
    if code == ABM4:
        return abm4_bounded_step(h, m)
    if code == ARK548:
        return ark548_bounded_step(h, m)
    return dopri5_bounded_step(h, m)


@kernel(inline=True)
def method_attempt(code, t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters):
    if code == ABM4:
        return abm4_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters)
    if code == ARK548:
        return ark548_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters)
    return dopri5_attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters)


@kernel(inline=True)
def method_after_rejection(code, control, step, err, finite):
    if code == ABM4:
        return abm4_after_rejection(control, step, err, finite)
    if code == ARK548:
        return ark548_after_rejection(control, step, err, finite)
    return dopri5_after_rejection(control, step, err, finite)


@kernel(inline=True)
def method_after_acceptance(code, control, step, err, event, restart, rejected_last, history, work, n, m, counters):
    if code == ABM4:
        abm4_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters)
    elif code == ARK548:
        ark548_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters)
    else:
        dopri5_after_acceptance(control, step, err, event, restart, rejected_last, history, work, n, m, counters)


@kernel
def _pass_valley(t, y, memory, ctx, window, out, lobe_records, records, work_rows, scratch, counters):
    """At the end valley: close the lobe's window (mechanics.loop.windows), cross to the next lobe and evaluate the
    rates there. Returns (lobe records written, False if a chamber state left the property table)."""
    m = ctx.machine[0]
    records = close_window(window, out, round(memory[MEM_LOBE_START] * m.lobes / (2.0 * math.pi)) + 1, lobe_records,
                           records)
    if not _cross_valley(t, y, memory, ctx, m.pressure_model == REAL_GAS_MODEL):
        return records, False
    counters[VALLEY_CROSSINGS] += 1
    evaluate(t, y, ctx, memory, work_rows[0], scratch, False)
    counters[EVALUATIONS] += 1
    return records, True


@kernel
def _cross_valley(t, y, memory, ctx, real_gas):
    """The vane crossed the end valley of its lobe: the next lobe becomes the active one and, under real gas, the
    chambers are switched (thermo.chamber_model.switch_chambers). Returns False if a chamber state left the
    property table."""
    m = ctx.machine[0]
    if not real_gas:
        memory[MEM_LOBE_START] += 2.0 * math.pi / m.lobes
        memory[MEM_LOBE_COUNT] += 1.0
        return True
    old_inputs = chamber_inputs_at(t, y, ctx, memory)
    memory[MEM_LOBE_START] += 2.0 * math.pi / m.lobes
    memory[MEM_LOBE_COUNT] += 1.0
    return switch_chambers(t, y, GAS_BLOCK, old_inputs, chamber_inputs_at(t, y, ctx, memory), ctx.chambers[0],
                           ctx.properties)


@kernel
def smallest_step(t, m):
    """h_min = 16 eps max(|t|, T_c) (docs/model.md §8.2): the step below which t + h no longer differs from t by
    more than a few units of rounding, so the error control cannot be met by any smaller step; the contact period
    T_c (mechanics.loop.machine.contact_period) is the time scale near t = 0."""
    return TIME_RESOLUTION * max(abs(t), m.contact_period)


@kernel
def _step_rejected(err, failure):
    """A step is rejected when its error is too large or its state invalid."""
    return err > 1.0 or failure != 0


RUNNING = -1                     # _after_rejection: the loop goes on (not a status of advance)


@kernel
def _after_rejection(method, control, step, err, failure, finite, t, m, counters):
    """Count a rejected step and shrink the next one (the method's rule); below the smallest step (smallest_step)
    the advance stops with the failure's status, or STEP_TOO_SMALL (NOT_FINITE for a non-finite state); else
    RUNNING."""
    counters[REJECTED] += 1
    control[CONTROL_STEP] = method_after_rejection(method, control, step, err, finite)
    if control[CONTROL_STEP] >= smallest_step(t, m):
        return RUNNING
    if failure != 0:
        return failure
    return STEP_TOO_SMALL if finite else NOT_FINITE


@kernel
def _replay_step(t, grid, grid_counts):
    """(True, the step to the next step end to follow) while a replayed grid lasts, else (False, 0): the recorded
    step from its recorded start (so a replay at the recorded input repeats the recorded advance bit for bit), else
    the step to the recorded end."""
    index = grid_counts[GRID_NEXT]
    if index < grid_counts[GRID_FOLLOW]:
        if t == grid[index, GRID_START]:
            return True, grid[index, GRID_STEP]
        return True, grid[index, GRID_END] - t
    return False, 0.0


@kernel
def _after_replayed_step(t, grid, grid_counts):
    """Move past the followed steps that t has reached, and past a step redone for a contact change once t has
    left its start (the step that landed on the change has been taken)."""
    while grid_counts[GRID_NEXT] < grid_counts[GRID_FOLLOW]:
        index = grid_counts[GRID_NEXT]
        if not (grid[index, GRID_END] <= t or (grid[index, GRID_REDONE] != 0.0 and grid[index, GRID_START] < t)):
            break
        grid_counts[GRID_NEXT] += 1


@kernel
def _record_step(start, step, end, redone, recorded, grid_counts):
    """Record a step the step control chose (not clipped by an event) that passed the error control: accepted, or
    redone to land on a contact change; past the capacity the count grows beyond it, which marks the record
    incomplete."""
    count = grid_counts[GRID_RECORDED]
    if count < recorded.shape[0]:
        recorded[count, GRID_START] = start
        recorded[count, GRID_STEP] = step
        recorded[count, GRID_END] = end
        recorded[count, GRID_REDONE] = 1.0 if redone else 0.0
    grid_counts[GRID_RECORDED] = count + 1


@kernel
def _replay_verdict(err, failure, step, control, grid_counts):
    """The error of a replayed step (docs/model.md §8.2): within REPLAY_ERROR_LIMIT and valid it is accepted
    (error at most 1); otherwise the replay ends here (GRID_FELL_BACK) and the step control takes over from this
    step, which is then judged by its own error."""
    if err <= REPLAY_ERROR_LIMIT and failure == 0:
        return min(err, 1.0)
    grid_counts[GRID_FOLLOW] = grid_counts[GRID_NEXT]
    grid_counts[GRID_FELL_BACK] = 1
    control[CONTROL_STEP] = step
    return err


@kernel
def _advanced_time(t, step, t_end, event, replaying, grid, grid_counts, recorded):
    """The time after an accepted step: t_end exactly at the end event, the recorded step end while a replay
    follows it (bit for bit), else t + step; a step the control chose is recorded for a later replay."""
    start = t
    if event == END_EVENT:
        t = t_end
    elif replaying and event == NO_EVENT:
        t = grid[grid_counts[GRID_NEXT], GRID_END]
    else:
        t = t + step
    if event == NO_EVENT:
        _record_step(start, step, t, False, recorded, grid_counts)
    _after_replayed_step(t, grid, grid_counts)
    return t


@kernel
def _commit_step(y, work_rows, scratch, out, memory, m, landed, counters):
    """Take the attempted step's state, first-stage rates and output row as the new ones, and update the contact
    memory with the contacts that landed; returns whether a contact mode changed."""
    n = y.size
    copy_values(y, 0, work_rows[W_Y_NEW], 0, n)
    copy_values(work_rows[0], 0, work_rows[STAGES - 1], 0, n)
    copy_values(scratch, 0, out, 0, out.size)
    mode_changed = _update_memory(out, memory, m, landed)
    counters[MODE_CHANGES] += mode_changed
    return mode_changed


@kernel
def _record_accepted(out, window, run_dwell, rows_out, rows, keep_rows):
    """Accumulate the lobe window (mechanics.loop.windows) and write the output row (row 0 unless keep_rows)."""
    accumulate(window, run_dwell, out)
    row = rows if keep_rows else 0
    for i in range(out.size):
        rows_out[row, i] = out[i]


@kernel
def advance(t, t_end, y, memory, control, history, window, run_dwell, ctx, work, work_rows, out, scratch, rows_out,
            keep_rows, lobe_records, counters, max_attempts, grid, recorded, grid_counts):
    """Integrate from t to t_end with the machine's method (module docstring; the methods above). y, memory,
    control, history, window, run_dwell and counters are updated in place; work is the workspace (WORKSPACE_ROWS
    rows) and work_rows the same rows as a tuple of arrays (a function without reference counting cannot take
    views); out and scratch are output rows; accepted output rows go to rows_out (all of them if keep_rows, else
    only the last in rows_out[0]), lobe records to lobe_records. At most max_attempts steps are attempted
    (accepted or rejected): then the status is WORK_LIMIT, so that no state (a step size of 0 or 5e-324, a time
    that does not advance) can make the loop spin.
    Step-grid replay (docs/model.md §8.2): while grid_counts[GRID_NEXT] < grid_counts[GRID_FOLLOW] the steps follow
    the recorded steps grid[GRID_NEXT:GRID_FOLLOW] (events still clip them; the step after an event goes to the next
    recorded end)
    and are accepted without error control unless their scaled error exceeds REPLAY_ERROR_LIMIT: then the replay
    ends (GRID_FELL_BACK) and the step control takes over. The end times of the steps the step control chose (not
    clipped by an event) are recorded in `recorded` (start, size, end, redone; count in grid_counts[GRID_RECORDED]), with
    the steps redone to land on a contact change: a replay at the recorded input repeats the advance bit for bit.
    Returns (status, t, rows written, lobe records written); NOT_FINITE if t or t_end is not a number."""
    m = ctx.machine[0]
    method = m.integrator
    n = y.size
    rows = 0
    records = 0
    evaluate(t, y, ctx, memory, work_rows[0], scratch, False)
    counters[EVALUATIONS] += 1
    method_begin(method, control, history, work, n)
    rejected_last = False
    attempts = 0
    contact_time = math.inf          # a located contact event ahead (docs/model.md §8.2, events)
    contact_slot = NO_SLOT
    while t < t_end:
        if (keep_rows and rows >= rows_out.shape[0]) or records >= lobe_records.shape[0]:
            return RECORD_FULL, t, rows, records
        if attempts >= max_attempts:
            return WORK_LIMIT, t, rows, records
        attempts += 1
        replaying, proposed = _replay_step(t, grid, grid_counts)
        if not replaying:
            control[CONTROL_STEP] = method_bounded_step(method, control[CONTROL_STEP], m)
            proposed = control[CONTROL_STEP]
        step, event = _clip_to_events(t, proposed, t_end, ctx.law, memory, m, contact_time)
        failure, err = method_attempt(method, t, step, event, y, ctx, memory, control, history, work, work_rows, out,
                                      counters)
        finite = _all_finite(work_rows[W_Y_NEW], n) and _all_finite(work_rows[STAGES - 1], n)
        if not finite:
            err = math.inf
        if replaying:
            err = _replay_verdict(err, failure, step, control, grid_counts)
        if _step_rejected(err, failure):
            rejected_last = True
            stop = _after_rejection(method, control, step, err, failure, finite, t, m, counters)
            if stop != RUNNING:
                return stop, t, rows, records
            continue
        landed = (1 << contact_slot) if event == CONTACT_EVENT else 0
        s, slot, at_end = _contact_changes(scratch, out, memory, step, landed, smallest_step(t, m) / step)
        if slot != NO_SLOT:
            contact_time = t + s * step              # redo the step to end on the earliest contact change
            contact_slot = slot
            counters[EVENT_RETRIES] += 1
            if event == NO_EVENT:
                _record_step(t, step, t + step, True, recorded, grid_counts)
            continue
        landed |= at_end
        contact_time = math.inf
        contact_slot = NO_SLOT
        counters[ACCEPTED] += 1
        t = _advanced_time(t, step, t_end, event, replaying, grid, grid_counts, recorded)
        mode_changed = _commit_step(y, work_rows, scratch, out, memory, m, landed, counters)
        _record_accepted(out, window, run_dwell, rows_out, rows, keep_rows)
        rows += 1
        if event == VALLEY_EVENT:
            records, crossed = _pass_valley(t, y, memory, ctx, window, out, lobe_records, records, work_rows, scratch,
                                            counters)
            if not crossed:
                return GAS_STATE_INVALID, t, rows, records
        restart = mode_changed or event == VALLEY_EVENT or event == RAMP_EVENT
        method_after_acceptance(method, control, step, err, event, restart, rejected_last, history, work, n, m,
                                counters)
        rejected_last = False
    return (REACHED_END if t >= t_end else NOT_FINITE), t, rows, records


@kernel(allocates=True)
def context(machine, law, pressure_table, chambers, flow_work, table_scalars, table_nodes, dome_limit, accurate_cell,
            ideal_gas_exponent, saturation_nodes, nozzle_header, nozzle_critical_ratio, nozzle_choked_flux_factor,
            nozzle_shape_factor, nozzle_throat_superheat, nozzle_viscosity, nozzle_dome_limit, nozzle_accurate_cell,
            nozzle_saturation_nodes, nozzle_dome_critical_ratio, nozzle_dome_choked_flux_factor,
            nozzle_dome_shape_factor, nozzle_dome_accurate_cell, sector_segments, sector_nodes):
    """The KernelContext of plain arrays: only arrays cross the Python -> numba boundary (a named tuple costs
    microseconds per call to unbox), the named records are built here."""
    return KernelContext(machine, law, pressure_table, chambers, flow_work,
                         table_from_arrays(table_scalars, table_nodes, dome_limit, accurate_cell,
                                           ideal_gas_exponent, saturation_nodes),
                         nozzle_table_from_arrays(nozzle_header, nozzle_critical_ratio, nozzle_choked_flux_factor,
                                                  nozzle_shape_factor, nozzle_throat_superheat, nozzle_viscosity,
                                                  nozzle_dome_limit, nozzle_accurate_cell, nozzle_saturation_nodes,
                                                  nozzle_dome_critical_ratio, nozzle_dome_choked_flux_factor,
                                                  nozzle_dome_shape_factor, nozzle_dome_accurate_cell),
                         SectorTable(sector_segments, sector_nodes))


@kernel(allocates=True)
def run(t, t_end, y, memory, control, history, window, run_dwell, work, outs, rows_out, keep_rows, lobe_records,
        counters, max_attempts, grid, recorded, grid_counts, *context_arrays):
    """`advance` with its context (the arrays of `context`, in its order) and workspace given as arrays (the entry
    point mechanics.simulation calls): the named records and the tuple of workspace rows are built here, once per
    advance."""
    ctx = context(*context_arrays)
    work_rows = (work[0], work[1], work[2], work[3], work[4], work[5], work[6], work[7], work[8], work[9], work[10])
    return advance(t, t_end, y, memory, control, history, window, run_dwell, ctx, work, work_rows, outs[0], outs[1],
                   rows_out, keep_rows, lobe_records, counters, max_attempts, grid, recorded, grid_counts)


@kernel(allocates=True)
def evaluate_state(t, y, memory, out, rates, *context_arrays):
    """dy/dt (into `rates`) and the output row (into `out`) of the state (t, y) with the given memory, as an
    accepted step would report it; returns the kernel status of the state. context_arrays: those of `context`."""
    return evaluate(t, y, context(*context_arrays), memory, rates, out, True)


@kernel(allocates=True)
def initial_chamber_inputs(t, y, memory, *context_arrays):
    """(V_L, V_T) geometric chamber volumes of the state (t, y), to fill the chambers at the start of a run."""
    inputs = chamber_inputs_at(t, y, context(*context_arrays), memory)
    return inputs.volume_leading, inputs.volume_trailing
