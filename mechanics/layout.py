"""Index layout of the arrays the time loop shares with Python (docs/model.md §8.1, ARCHITECTURE "State").

- state y: vane pose and velocity, then the work integrals W_in, W_out, W_fric, W_damp (docs/model.md §6.4);
- memory: non-state values updated only after accepted steps (warm start, lobe, impact velocities, mode);
- outputs: the quantities re-evaluated at each accepted step (docs/model.md §8.1b), one row of the history.
"""

# state vector
X, Y, ANGLE, VX, VY, ANGULAR_VELOCITY, WORK_IN, WORK_OUT, WORK_FRICTION, WORK_DAMPING = range(10)
STATE_SIZE = 10
# Level 1 (real gas) adds the chamber states (T, rho) of the leading and trailing chambers and the cumulative
# flows across the chambers' boundary (docs/model.md §7.2-§7.3): net mass and energy from the suction side (ports, valley
# leak, chambers filled from or vented to the idle lobes), mass and enthalpy out through the discharge valve, and
# the compression work -sum p dV on the two chambers.
(LEADING_TEMPERATURE, LEADING_DENSITY, TRAILING_TEMPERATURE, TRAILING_DENSITY, MASS_SUCTION, MASS_DISCHARGE,
 ENERGY_SUCTION, ENERGY_DISCHARGE, WORK_CHAMBERS) = range(STATE_SIZE, STATE_SIZE + 9)
REAL_GAS_STATE_SIZE = STATE_SIZE + 9

# memory
MEM_CLOSEST_OFFSET = 0         # warm start: u* minus the polar angle of the tip centre, last accepted step
MEM_LOBE_START = 1             # rotor angle of the valley that opened the current lobe
MEM_ONSET_VELOCITY = 2         # 5 slots: c1, c2, c3, c4 and the tip (c5/c6 share one, the tip contact is one)
MEM_MODE = 7                   # contact-mode mask of the last accepted step
MEM_LOBE_COUNT = 8             # valley crossings so far
MEMORY_SIZE = 9
TIP_MEMORY_SLOT = 4

REGIONS = 6
OUTPUT_NAMES = (
    "time", "rotor_angle", "rotor_speed", "rotor_acceleration",
    "vane_displacement", "vane_radial_velocity", "vane_radial_acceleration",
    "vane_tangential_velocity", "vane_tangential_acceleration", "vane_tilt",
    *(f"normal_force_{k}" for k in range(1, 7)),
    *(f"friction_force_{k}" for k in range(1, 7)),
    *(f"penetration_{k}" for k in range(1, 7)),
    *(f"penetration_rate_{k}" for k in range(1, 7)),
    "contact_mode", "mouth_candidate_1", "mouth_candidate_2",
    "stator_force_x", "stator_force_y", "stator_contact_moment", "stator_gas_moment", "gap_moment",
    "rotor_force_x", "rotor_force_y", "driving_torque",
    "input_power", "output_power", "friction_power", "damping_power",
    "leading_pressure", "trailing_pressure", "kinetic_energy", "contact_energy",
    "contact_angle", "closest_parameter_offset", "lobe_count",
    "work_in", "work_out", "work_friction", "work_damping",
    "leading_temperature", "trailing_temperature", "leading_volume", "trailing_volume", "chamber_mass",
    "chamber_internal_energy", "suction_mass_flow", "discharge_mass_flow", "tip_leak_mass_flow", "valley_leak_mass_flow",
    "mass_suction", "mass_discharge", "energy_suction", "energy_discharge", "work_chambers",
)
OUTPUT_INDEX = {name: i for i, name in enumerate(OUTPUT_NAMES)}
OUTPUT_SIZE = len(OUTPUT_NAMES)

(O_TIME, O_ANGLE, O_SPEED, O_ACCELERATION, O_DISPLACEMENT, O_RADIAL_VELOCITY, O_RADIAL_ACCELERATION,
 O_TANGENTIAL_VELOCITY, O_TANGENTIAL_ACCELERATION, O_TILT) = range(10)
O_NORMAL_FORCE = OUTPUT_INDEX["normal_force_1"]
O_FRICTION_FORCE = OUTPUT_INDEX["friction_force_1"]
O_PENETRATION = OUTPUT_INDEX["penetration_1"]
O_PENETRATION_RATE = OUTPUT_INDEX["penetration_rate_1"]
O_MODE = OUTPUT_INDEX["contact_mode"]
O_CANDIDATE = OUTPUT_INDEX["mouth_candidate_1"]
O_STATOR_FORCE = OUTPUT_INDEX["stator_force_x"]
O_STATOR_MOMENT = OUTPUT_INDEX["stator_contact_moment"]
O_STATOR_GAS_MOMENT = OUTPUT_INDEX["stator_gas_moment"]
O_GAP_MOMENT = OUTPUT_INDEX["gap_moment"]
O_ROTOR_FORCE = OUTPUT_INDEX["rotor_force_x"]
O_DRIVING_TORQUE = OUTPUT_INDEX["driving_torque"]
O_INPUT_POWER = OUTPUT_INDEX["input_power"]
O_OUTPUT_POWER = OUTPUT_INDEX["output_power"]
O_FRICTION_POWER = OUTPUT_INDEX["friction_power"]
O_DAMPING_POWER = OUTPUT_INDEX["damping_power"]
O_LEADING_PRESSURE = OUTPUT_INDEX["leading_pressure"]
O_TRAILING_PRESSURE = OUTPUT_INDEX["trailing_pressure"]
O_KINETIC_ENERGY = OUTPUT_INDEX["kinetic_energy"]
O_CONTACT_ENERGY = OUTPUT_INDEX["contact_energy"]
O_CONTACT_ANGLE = OUTPUT_INDEX["contact_angle"]
O_CLOSEST_OFFSET = OUTPUT_INDEX["closest_parameter_offset"]
O_LOBE_COUNT = OUTPUT_INDEX["lobe_count"]
O_WORK = OUTPUT_INDEX["work_in"]
O_LEADING_TEMPERATURE = OUTPUT_INDEX["leading_temperature"]
O_LEADING_VOLUME = OUTPUT_INDEX["leading_volume"]
O_CHAMBER_MASS = OUTPUT_INDEX["chamber_mass"]
O_CHAMBER_ENERGY = OUTPUT_INDEX["chamber_internal_energy"]
O_SUCTION_MASS_FLOW = OUTPUT_INDEX["suction_mass_flow"]
O_MASS_SUCTION = OUTPUT_INDEX["mass_suction"]
REAL_GAS_OUTPUT_NAMES = OUTPUT_NAMES[O_LEADING_TEMPERATURE:]     # NaN (not modelled) under the pressure tables

# kernel status codes (0 = reached the end time)
REACHED_END, RECORD_FULL, STEP_TOO_SMALL, NOT_FINITE, TIP_ON_FLAT_FACE, VANE_BOTTOMED, GAS_STATE_INVALID = range(7)
STATUS_TEXT = {
    STEP_TOO_SMALL: "the step size fell below min_step",
    NOT_FINITE: "the state became non-finite",
    TIP_ON_FLAT_FACE: "the stator touches a flat face of the vane (|psi_c| > pi/2, docs/model.md §2.6)",
    VANE_BOTTOMED: "the vane reached the slot bottom (docs/model.md §4.3)",
    GAS_STATE_INVALID: "a chamber state left the fluid property table (two-phase dome or outside its envelope)",
}
