"""Index layout of the state and memory arrays the time loop shares with Python, and its status codes
(docs/model.md §8.1). The output row's layout is in mechanics.loop.outputs.

- state y: vane pose and velocity, then the work integrals W_in, W_out, W_fric, W_damp, the work of the
  elastic contact forces W_el and the two parts of W_out, the indicated work W_ind and the gap work W_gap
  (docs/model.md §6.4);
  under real gas the chamber model's state block follows (thermo.chamber_model, from GAS_BLOCK on);
- memory: non-state values updated only after accepted steps (warm start, lobe, impact velocities, mode).
"""
from ...thermo.chamber_model import GAS_STATE_SIZE

from ..contact.regions import MEMORY_SLOTS

# state vector
(X, Y, ANGLE, VX, VY, ANGULAR_VELOCITY, WORK_IN, WORK_OUT, WORK_FRICTION, WORK_DAMPING, WORK_ELASTIC, WORK_INDICATED,
 WORK_GAP) = range(13)
VANE_STATE_SIZE = 13
GAS_BLOCK = VANE_STATE_SIZE                      # first index of the chamber states (real gas)
REAL_GAS_STATE_SIZE = VANE_STATE_SIZE + GAS_STATE_SIZE

# memory
MEM_CLOSEST_OFFSET = 0         # warm start: u* minus the polar angle of the tip centre, last accepted step
MEM_LOBE_START = 1             # rotor angle of the valley that opened the current lobe
MEM_ONSET_VELOCITY = 2         # one slot per impact-velocity memory of mechanics.contact.regions (c5/c6 share one)
MEM_MODE = MEM_ONSET_VELOCITY + MEMORY_SLOTS     # contact-mode mask of the last accepted step
MEM_LOBE_COUNT = MEM_MODE + 1  # valley crossings so far
MEM_LAW_EXCESS = MEM_MODE + 2  # largest penetration beyond a force law's validity limit so far (docs/model.md §5.2)
MEMORY_SIZE = MEM_MODE + 3

# kernel status codes (0 = reached the end time)
REACHED_END, RECORD_FULL, STEP_TOO_SMALL, NOT_FINITE, TIP_ON_FLAT_FACE, GAS_STATE_INVALID, WORK_LIMIT = range(7)
STATUS_TEXT = {
    STEP_TOO_SMALL: "the step size fell below the time resolution 16 eps max(|t|, T_c) (docs/model.md §8.2): the "
                    "error tolerances cannot be met in floating point",
    NOT_FINITE: "the state became non-finite",
    TIP_ON_FLAT_FACE: "the stator touches a flat face of the vane (|psi_c| > pi/2, docs/model.md §2.6)",
    GAS_STATE_INVALID: "a chamber state left the fluid property table (two-phase dome or outside its envelope)",
    WORK_LIMIT: "the integrator attempted more steps than the work bound allows for this interval "
                "(mechanics.simulation.work_bound)",
}
