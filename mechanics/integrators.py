"""The time loop: adaptive Dormand-Prince 5(4) and the thesis's ABM4 PECE with RK4 start (docs/model.md §8.2).

Each kernel is entered once per advance and runs until the end time, a full history buffer or a failure. Both
share the step bookkeeping: events (valley crossing, end of the speed ramp, the end time) clip the step to land on
them; a step is rejected when its error is too large, when a contact opened deeper than max_onset_penetration,
or when the state is invalid; the memory (warm start, impact velocities, mode, lobe) changes only after an
accepted step, whose output row is recorded.
"""
import math

import numpy as np
from numba import njit

from .dynamics import cross_valley, evaluate
from .layout import (ANGLE, ANGULAR_VELOCITY, GAS_STATE_INVALID, LEADING_DENSITY, LEADING_TEMPERATURE, MASS_DISCHARGE,
                     MASS_SUCTION, MEM_CLOSEST_OFFSET, MEM_LOBE_START, MEM_MODE, MEM_ONSET_VELOCITY, NOT_FINITE,
                     O_CLOSEST_OFFSET, O_CONTACT_ANGLE, O_MODE, O_PENETRATION, O_PENETRATION_RATE, OUTPUT_SIZE,
                     REACHED_END, RECORD_FULL, REGIONS, STEP_TOO_SMALL, TIP_MEMORY_SLOT, TRAILING_DENSITY,
                     TRAILING_TEMPERATURE, VX, VY, X, Y)
from .speed import ramp_end_time, rotor_motion, time_of_angle

# counters shared with Python
ACCEPTED, REJECTED, EVALUATIONS, VALLEY_CROSSINGS, MODE_CHANGES, RESTARTS = range(6)
COUNTER_SIZE = 6
# control values kept between advances
CONTROL_STEP, CONTROL_HISTORY, CONTROL_SMALL_ERRORS, CONTROL_PREVIOUS_ERROR = range(4)
CONTROL_SIZE = 4
PI_BETA = 0.04                      # Hairer's DOPRI5 step-size stabilisation
ABM_HISTORY = 7                     # points kept at the current spacing (step doubling reuses every second one)

NO_EVENT, END_EVENT, RAMP_EVENT, VALLEY_EVENT = range(4)


@njit(cache=True)
def _tolerance(i, value, m):
    """atol_i + rtol |y_i| with the absolute tolerances of docs/model.md §8.2 (and of the Level 1 gas states)."""
    if i == X or i == Y:
        atol = m.atol_position
    elif i == ANGLE:
        atol = m.atol_angle
    elif i == VX or i == VY:
        atol = m.atol_velocity
    elif i == ANGULAR_VELOCITY:
        atol = m.atol_angular_velocity
    elif i == LEADING_TEMPERATURE or i == TRAILING_TEMPERATURE:
        atol = m.atol_temperature
    elif i == LEADING_DENSITY or i == TRAILING_DENSITY:
        atol = m.atol_density
    elif i == MASS_SUCTION or i == MASS_DISCHARGE:
        atol = m.atol_mass
    else:
        atol = m.atol_work
    return atol + m.relative_tolerance * abs(value)


@njit(cache=True)
def _error_norm(y_new, error, m):
    """max_i |error_i| / (atol_i + rtol |y_i|), the norm of docs/model.md §8.2 (ABM4)."""
    worst = 0.0
    for i in range(y_new.size):
        worst = max(worst, abs(error[i]) / _tolerance(i, y_new[i], m))
    return worst


@njit(cache=True)
def _error_rms(y_old, y_new, error, m):
    """sqrt(mean_i (error_i / (atol_i + rtol max(|y_old,i|, |y_new,i|)))^2), Hairer's DOPRI5 norm."""
    total = 0.0
    for i in range(y_new.size):
        total += (error[i] / _tolerance(i, max(abs(y_old[i]), abs(y_new[i])), m)) ** 2
    return math.sqrt(total / y_new.size)


@njit(cache=True)
def _opened_too_deep(out, memory, m):
    """True if a contact that was open at the start of the step closed with delta > max_onset_penetration."""
    for region in range(REGIONS):
        slot = TIP_MEMORY_SLOT if region >= 4 else region
        if out[O_PENETRATION + region] > m.max_onset_penetration and memory[MEM_ONSET_VELOCITY + slot] <= 0.0:
            return True
    return False


@njit(cache=True)
def _all_finite(values):
    for v in values:
        if not math.isfinite(v):
            return False
    return True


@njit(cache=True)
def _stop_status(failure, finite):
    """Why a run stopped when the step fell below min_step: the state check that failed, a non-finite state,
    or the error control itself."""
    if failure != 0:
        return failure
    return STEP_TOO_SMALL if finite else NOT_FINITE


@njit(cache=True)
def _clip_to_events(t, step, t_end, law, memory, m):
    """Shorten the step to land on the next event inside it; return (step, event kind)."""
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
    return step, event


@njit(cache=True)
def _accept(out, memory, m):
    """Update the memory after an accepted step (docs/model.md §5.1, §8.1); return True if the contact mode changed."""
    memory[MEM_CLOSEST_OFFSET] = out[O_CLOSEST_OFFSET]
    tip_region = 4 if out[O_CONTACT_ANGLE] > 0.0 else 5
    for slot in range(5):
        region = tip_region if slot == TIP_MEMORY_SLOT else slot
        if out[O_PENETRATION + region] > 0.0:
            if memory[MEM_ONSET_VELOCITY + slot] <= 0.0:
                memory[MEM_ONSET_VELOCITY + slot] = max(abs(out[O_PENETRATION_RATE + region]),
                                                        m.onset_velocity_floor)
        else:
            memory[MEM_ONSET_VELOCITY + slot] = 0.0
    changed = out[O_MODE] != memory[MEM_MODE]
    memory[MEM_MODE] = out[O_MODE]
    return changed


@njit(cache=True)
def _combine(target, y, h, c1, k1, c2, k2, c3, k3, c4, k4, c5, k5, c6, k6):
    """target = y + h (c1 k1 + ... + c6 k6), element by element (no temporaries in the hot loop)."""
    for i in range(y.size):
        target[i] = y[i] + h * (c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + c4 * k4[i] + c5 * k5[i] + c6 * k6[i])


# Dormand-Prince 5(4) tableau
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = 9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
                          -1.0 / 40.0)


@njit(cache=True)
def advance_dopri5(t, y, t_end, m, law, gas, memory, control, record, counters):
    """Adaptive Dormand-Prince 5(4) with FSAL, Hairer's RMS error norm and PI step control (DOPRI5):

    h_new = h min(10, max(0.2, 0.9 err^-(0.2 - 0.75 beta) err_prev^beta)),  beta = 0.04, after a rejection no growth.

    Returns (status, t, rows recorded). y, memory, control and counters are updated in place.
    """
    n = y.size
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    k7 = np.empty(n)
    stage = np.empty(n)
    y_new = np.empty(n)
    error = np.empty(n)
    zero = np.zeros(n)
    out = np.empty(OUTPUT_SIZE)
    rows = 0
    evaluate(t, y, m, law, gas, memory, k1, out)
    counters[EVALUATIONS] += 1
    h = control[CONTROL_STEP]
    previous_error = control[CONTROL_PREVIOUS_ERROR] if control[CONTROL_PREVIOUS_ERROR] > 0.0 else 1e-4
    rejected_last = False
    failure = 0
    while t < t_end:
        if rows >= record.shape[0]:
            control[CONTROL_STEP] = h
            control[CONTROL_PREVIOUS_ERROR] = previous_error
            return RECORD_FULL, t, rows
        h = min(h, m.max_step)
        step, event = _clip_to_events(t, h, t_end, law, memory, m)
        _combine(stage, y, step, A21, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1)
        failure = evaluate(t + step / 5.0, stage, m, law, gas, memory, k2, out, False)
        _combine(stage, y, step, A31, k1, A32, k2, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1)
        failure |= evaluate(t + 3.0 * step / 10.0, stage, m, law, gas, memory, k3, out, False)
        _combine(stage, y, step, A41, k1, A42, k2, A43, k3, 0.0, k1, 0.0, k1, 0.0, k1)
        failure |= evaluate(t + 4.0 * step / 5.0, stage, m, law, gas, memory, k4, out, False)
        _combine(stage, y, step, A51, k1, A52, k2, A53, k3, A54, k4, 0.0, k1, 0.0, k1)
        failure |= evaluate(t + 8.0 * step / 9.0, stage, m, law, gas, memory, k5, out, False)
        _combine(stage, y, step, A61, k1, A62, k2, A63, k3, A64, k4, A65, k5, 0.0, k1)
        failure |= evaluate(t + step, stage, m, law, gas, memory, k6, out, False)
        _combine(y_new, y, step, B1, k1, B3, k3, B4, k4, B5, k5, B6, k6, 0.0, k1)
        failure |= evaluate(t + step, y_new, m, law, gas, memory, k7, out)
        counters[EVALUATIONS] += 6
        _combine(error, zero, step, E1, k1, E3, k3, E4, k4, E5, k5, E6, k6, E7, k7)
        finite = _all_finite(y_new) and _all_finite(error)
        err = _error_rms(y, y_new, error, m) if finite else math.inf
        if err > 1.0 or failure != 0 or _opened_too_deep(out, memory, m):
            counters[REJECTED] += 1
            rejected_last = True
            if err > 1.0 and finite:
                h = step * max(0.2, 0.9 * err ** -(0.2 - 0.75 * PI_BETA))
            else:
                h = 0.5 * step
            if h < m.min_step:
                control[CONTROL_STEP] = h
                return _stop_status(failure, finite), t, rows
            continue
        counters[ACCEPTED] += 1
        t = t_end if event == END_EVENT else t + step
        y[:] = y_new
        k1, k7 = k7, k1
        record[rows, :] = out
        rows += 1
        if _accept(out, memory, m):
            counters[MODE_CHANGES] += 1
        if event == VALLEY_EVENT:
            if not cross_valley(t, y, memory, m, law, gas):
                control[CONTROL_STEP] = h
                return GAS_STATE_INVALID, t, rows
            counters[VALLEY_CROSSINGS] += 1
            evaluate(t, y, m, law, gas, memory, k1, out)
            counters[EVALUATIONS] += 1
        err = max(err, 1e-10)
        factor = min(10.0, max(0.2, 0.9 * err ** -(0.2 - 0.75 * PI_BETA) * previous_error ** PI_BETA))
        if rejected_last:
            factor = min(factor, 1.0)
        previous_error = max(err, 1e-4)
        rejected_last = False
        h = max(h, step * factor) if event != NO_EVENT else step * factor
    control[CONTROL_STEP] = h
    control[CONTROL_PREVIOUS_ERROR] = previous_error
    return REACHED_END, t, rows


@njit(cache=True)
def _rk4_step(t, y, h, k1, m, law, gas, memory, k2, k3, k4, stage, y_new, out):
    """Classical RK4 (thesis Table 4.1): y+ = y + h (k1 + 2 k2 + 2 k3 + k4)/6, k1 given."""
    _combine(stage, y, 0.5 * h, 1.0, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1)
    failure = evaluate(t + 0.5 * h, stage, m, law, gas, memory, k2, out, False)
    _combine(stage, y, 0.5 * h, 1.0, k2, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1)
    failure |= evaluate(t + 0.5 * h, stage, m, law, gas, memory, k3, out, False)
    _combine(stage, y, h, 1.0, k3, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1, 0.0, k1)
    failure |= evaluate(t + h, stage, m, law, gas, memory, k4, out, False)
    _combine(y_new, y, h / 6.0, 1.0, k1, 2.0, k2, 2.0, k3, 1.0, k4, 0.0, k1, 0.0, k1)
    return failure


@njit(cache=True)
def advance_abm4(t, y, t_end, m, law, gas, memory, control, history, record, counters):
    """ABM4 PECE with RK4 start, Milne error estimate and step halving/doubling (docs/model.md §8.2).

    AB4:  y^p = y_n + h/24 (55 f_n - 59 f_n-1 + 37 f_n-2 - 9 f_n-3);  AM4: y^c = y_n + h/24 (9 f^p + 19 f_n - 5 f_n-1 + f_n-2)
    LTE ~ 19/270 (y^c - y^p).  history[j] = f_n-j at spacing h; control[CONTROL_HISTORY] counts valid points.
    Steps that must land on an event, and the first three after a restart, are RK4 steps.
    Returns (status, t, rows recorded).
    """
    n = y.size
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    stage = np.empty(n)
    y_new = np.empty(n)
    y_pred = np.empty(n)
    f_pred = np.empty(n)
    f_new = np.empty(n)
    error = np.empty(n)
    out = np.empty(OUTPUT_SIZE)
    rows = 0
    h = control[CONTROL_STEP]
    valid = int(control[CONTROL_HISTORY])
    small_errors = int(control[CONTROL_SMALL_ERRORS])
    if valid < 1:
        evaluate(t, y, m, law, gas, memory, history[0], out)
        counters[EVALUATIONS] += 1
        valid = 1
    while t < t_end:
        if rows >= record.shape[0]:
            break
        step, event = _clip_to_events(t, h, t_end, law, memory, m)
        multistep = valid >= 4 and event == NO_EVENT
        if multistep:
            _combine(y_pred, y, h / 24.0, 55.0, history[0], -59.0, history[1], 37.0, history[2], -9.0, history[3],
                     0.0, f_new, 0.0, f_new)
            failure = evaluate(t + h, y_pred, m, law, gas, memory, f_pred, out, False)
            _combine(y_new, y, h / 24.0, 9.0, f_pred, 19.0, history[0], -5.0, history[1], 1.0, history[2],
                     0.0, f_new, 0.0, f_new)
            counters[EVALUATIONS] += 1
            for i in range(n):
                error[i] = 19.0 / 270.0 * (y_new[i] - y_pred[i])
        else:
            failure = _rk4_step(t, y, step, history[0], m, law, gas, memory, k2, k3, k4, stage, y_new,
                                out)
            counters[EVALUATIONS] += 3
            error[:] = 0.0
        failure |= evaluate(t + step, y_new, m, law, gas, memory, f_new, out)
        counters[EVALUATIONS] += 1
        finite = _all_finite(y_new) and _all_finite(f_new)
        err = _error_norm(y_new, error, m) if finite else math.inf
        if err > 1.0 or failure != 0 or _opened_too_deep(out, memory, m):
            counters[REJECTED] += 1
            h = 0.5 * min(h, step)
            valid = 1
            small_errors = 0
            if h < m.min_step:
                control[CONTROL_STEP] = h
                control[CONTROL_HISTORY] = valid
                return _stop_status(failure, finite), t, rows
            continue
        counters[ACCEPTED] += 1
        t = t_end if event == END_EVENT else t + step
        y[:] = y_new
        record[rows, :] = out
        rows += 1
        if event == NO_EVENT:
            for j in range(ABM_HISTORY - 1, 0, -1):
                history[j, :] = history[j - 1]
            history[0, :] = f_new
            valid = min(valid + 1, ABM_HISTORY)
        else:
            history[0, :] = f_new
            valid = 1
        mode_changed = _accept(out, memory, m)
        if mode_changed:
            counters[MODE_CHANGES] += 1
        if event == VALLEY_EVENT:
            if not cross_valley(t, y, memory, m, law, gas):
                control[CONTROL_STEP] = h
                return GAS_STATE_INVALID, t, rows
            counters[VALLEY_CROSSINGS] += 1
            evaluate(t, y, m, law, gas, memory, history[0], out)
            counters[EVALUATIONS] += 1
        if mode_changed or event == VALLEY_EVENT or event == RAMP_EVENT:
            valid = 1
            counters[RESTARTS] += 1
        small_errors = small_errors + 1 if (multistep and err < 1.0 / 50.0) else 0
        if small_errors >= 8 and 2.0 * h <= m.max_step:
            if valid >= ABM_HISTORY:
                for j in range(1, 4):
                    history[j, :] = history[2 * j]
                valid = 4
            else:
                valid = 1
            h *= 2.0
            small_errors = 0
    control[CONTROL_STEP] = h
    control[CONTROL_HISTORY] = valid
    control[CONTROL_SMALL_ERRORS] = small_errors
    return (REACHED_END if t >= t_end else RECORD_FULL), t, rows
