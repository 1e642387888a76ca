/* Compiled cable law: the laws of _laws.py as MuJoCo user-actuator callbacks.
 *
 * Each cable is one MuJoCo actuator on its tendon with user dynamics, a gain and user bias.
 * Everything the law needs lives in the model and the data, so the callbacks keep no state and
 * are safe to run from many threads at once (mujoco.rollout, mujoco.batch):
 *   act          rest length l [m], peak load-cell tension [N], peak line speed |dl/dt|
 *                [m/s] and power [W], and for DC motors (TENSIM_DC_ACTDIM) the spool's line
 *                speed dl/dt [m/s]
 *   ctrl[cadr]   V* [m/s] (impedance mode) or the commanded rest length [m] (rest mode)
 *   pull         the implicit law's last activation: -theta while taut after the motor step
 *   dynprm, gainprm, biasprm  the law's parameters; their slots are named in _cable_layout.h,
 *                generated from the one specification, tensim/model/_law_layout.py
 * The dynamics callback moves the rest length one motor step (its rate into act_dot) and keeps
 * the running peaks; the bias callback returns -f, the tension from the rest length after that
 * step (exactly as MuJoCo's Euler step will integrate it: l + l_dot * dt).
 * The implicit law (an affine gain, k x + b xdot, times the pull) differs only in that: the
 * dynamics callback also sets the pull, and the bias callback returns -f minus MuJoCo's gain
 * term, so that MuJoCo's force, gain term + bias, is -f while its implicit integrator sees the
 * term's derivatives (-theta k and -theta b while taut; none while slack or clamped): theta
 * of them implicit, the rest explicit (TENSIM_THETA_*).
 * The marker in dynprm selects the law's body per model: TENSIM_CABLE_MARKER runs the law
 * below, TENSIM_REFERENCE_MARKER hands the actuator to the Python reference law (registered
 * by tensim.sim._law), so one process can step models of either kind at once. Actuators
 * with neither marker go to the callback installed before tensim's, if any.
 * Every operation mirrors _laws.py in the same order, so the two agree to rounding.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>

#include <mujoco/mujoco.h>

#include "_cable_layout.h"

/* slots of dynprm (P), biasprm (B) and act (A), from the generated layout */
#define P(name) p[TENSIM_P_##name]
#define G(name) g[TENSIM_G_##name]
#define B(name) b[TENSIM_B_##name]

static mjfAct previous_dyn = NULL;
static mjfAct previous_bias = NULL;
static mjfAct reference_dyn = NULL;
static mjfAct reference_bias = NULL;

int tensim_header_version(void) { return mjVERSION_HEADER; }

/* Sets the callbacks that actuators other than tensim's are handed to (NULL: none). */
void tensim_set_previous(mjfAct dyn, mjfAct bias) {
  previous_dyn = dyn;
  previous_bias = bias;
}

/* Sets the Python reference law's callbacks, for actuators marked TENSIM_REFERENCE_MARKER. */
void tensim_set_reference(mjfAct dyn, mjfAct bias) {
  reference_dyn = dyn;
  reference_bias = bias;
}

double tensim_marker(void) { return TENSIM_CABLE_MARKER; }

/* The checksum of the parameter layout this library was built with (see _cable_layout.h). */
unsigned int tensim_layout_id(void) { return TENSIM_LAYOUT_ID; }

/* Whether actuator i runs the implicit law (MuJoCo's affine gain). */
static int implicit_law(const mjModel* m, int i) {
  return m->actuator_gaintype[i] == mjGAIN_AFFINE;
}

/* The marker of a tensim cable actuator (0 for any other actuator). */
static double cable_marker(const mjModel* m, int i) {
  int actnum = m->actuator_actnum[i] - TENSIM_IMPLICIT_EXTRA * implicit_law(m, i);
  double marker = m->actuator_dynprm[i * mjNDYN + TENSIM_P_MARKER];
  if (actnum != TENSIM_ACTDIM && actnum != TENSIM_DC_ACTDIM) return 0.0;
  return marker == TENSIM_CABLE_MARKER || marker == TENSIM_REFERENCE_MARKER ? marker : 0.0;
}

/* DC motor: one step of the spool's line speed act[adr + TENSIM_A_SPEED] under its torque-speed
 * curve, inertia, friction and the cable's tension (_laws.dc_drive, _laws.dc_motor_speed);
 * writes the speed's rate and returns the new rest length. */
static double dc_step(const mjModel* m, const mjData* d, int i, const mjtNum* p,
                      const mjtNum* g, const mjtNum* b, double target, double x, double v,
                      double rest, double dt) {
  int adr = m->actuator_actadr[i];
  double speed = d->act[adr + TENSIM_A_SPEED];
  double stretch = x - rest;
  double measured = stretch > 0.0 ? G(STIFFNESS) * stretch : 0.0;
  double applied = stretch > 0.0 ? fmax(measured + G(DAMPING) * v, 0.0) : 0.0;
  /* position loop: full voltage at an error of v0 t_p; no reeling in past the limits */
  double error = (target - rest) / (B(NO_LOAD_SPEED) * B(POSITION_TIME));
  double drive = fmin(fmax(error, -1.0), 1.0);
  if (drive < 0.0 && (measured >= P(MAX_TENSION) || x <= P(MIN_LENGTH))) drive = 0.0;
  /* backward Euler in the speed, Coulomb friction set-valued (the spool may stick) */
  double inertia = B(MASS) + dt * (B(STALL_FORCE) / B(NO_LOAD_SPEED) + B(VISCOUS));
  double free = (B(MASS) * speed + dt * (applied + B(STALL_FORCE) * drive)) / inertia;
  double slip = dt * B(COULOMB) / inertia;
  double next_speed = fabs(free) > slip ? free - copysign(slip, free) : 0.0;
  if (B(BACK_DRIVABLE) == 0.0) { /* a worm gear: the spool turns only where the motor drives it */
    if (drive > 0.0) {
      next_speed = fmax(next_speed, 0.0);
    } else if (drive < 0.0) {
      next_speed = fmin(next_speed, 0.0);
    } else {
      next_speed = 0.0;
    }
  }
  double next = rest + next_speed * dt;
  if (next < P(MIN_REST)) { /* the floor on the rest length stops the spool */
    next = P(MIN_REST);
    next_speed = 0.0;
  }
  mjtNum* act_dot = (mjtNum*)d->act_dot;
  act_dot[adr + TENSIM_A_SPEED] = (next_speed - speed) / dt;
  return next;
}

/* A PD motor's tension-only pull (_laws.pd_tension): kp (x - L) + kd v in [0, max_tension],
 * L the target (the command); the static part leaves out the damping. */
static double pd_static(const mjtNum* p, const mjtNum* g, double x, double target) {
  return fmin(fmax(G(PD_STIFFNESS) * (x - target), 0.0), P(MAX_TENSION));
}

static double pd_applied(const mjtNum* p, const mjtNum* g, double x, double v, double target) {
  return fmin(fmax(G(PD_STIFFNESS) * (x - target) + G(PD_DAMPING) * v, 0.0), P(MAX_TENSION));
}

/* The rest length after this step's motor update, as Euler integration will store it. */
static double next_rest(const mjModel* m, const mjData* d, int i) {
  int adr = m->actuator_actadr[i];
  return d->act[adr + TENSIM_A_REST] + d->act_dot[adr + TENSIM_A_REST] * m->opt.timestep;
}

mjtNum tensim_act_dyn(const mjModel* m, const mjData* d, int i) {
  double marker = cable_marker(m, i);
  if (marker == 0.0) return previous_dyn ? previous_dyn(m, d, i) : 0.0;
  if (marker == TENSIM_REFERENCE_MARKER) return reference_dyn ? reference_dyn(m, d, i) : NAN;
  const mjtNum* p = m->actuator_dynprm + i * mjNDYN;
  const mjtNum* g = m->actuator_gainprm + i * mjNGAIN;
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  int tendon = m->actuator_trnid[2 * i];
  int adr = m->actuator_actadr[i];
  int implicit = implicit_law(m, i);
  double dt = m->opt.timestep;
  double x = d->ten_length[tendon], v = d->ten_velocity[tendon];
  double k = G(STIFFNESS), rest = d->act[adr + TENSIM_A_REST], input = d->ctrl[m->actuator_ctrladr[i]];
  double target;
  if (P(MODE) == TENSIM_MODE_IMPEDANCE) {
    /* impedance law (eq. 3): the rest length that turns the measured tension into T_set */
    double stretch = x - rest;
    double measured = stretch > 0.0 ? k * stretch : 0.0;
    double set = fmax(0.0, P(OFFSET_TENSION) + P(GAIN_K) * (x - P(TARGET_LENGTH)) +
                                P(GAIN_B) * (v - input));
    target = rest - (set - measured) / k;
  } else if (P(MODE) == TENSIM_MODE_PD) {
    target = rest; /* a PD motor's command is its target length: the rest length stays */
  } else {
    target = input;
  }
  double next;
  if (m->actuator_actnum[i] - TENSIM_IMPLICIT_EXTRA * implicit == TENSIM_DC_ACTDIM) {
    next = dc_step(m, d, i, p, g, b, target, x, v, rest, dt);
  } else {
    /* motor: at most max_speed, never reeling in past max_tension or below the floors */
    /* lag: a share 1 - exp(-dt / lag_time) of the way to the target (all of it: no lag) */
    double share = B(LAG_TIME) > 0.0 ? 1.0 - exp(-dt / B(LAG_TIME)) : 1.0;
    double reach = P(MAX_SPEED) * dt;
    double step = fmin(fmax((target - rest) * share, -reach), reach);
    next = rest + step;
    if (step < 0.0) {
      double force_floor = fmin(rest, x - P(MAX_TENSION) / k);
      next = fmax(next, force_floor);
      if (x <= P(MIN_LENGTH)) next = rest;
    }
    /* a saturating force cap: pay out to where the static tension is max_tension */
    if (B(SATURATE) != 0.0) next = fmax(next, x - P(MAX_TENSION) / k);
    next = fmax(next, P(MIN_REST));
  }
  mjtNum* act_dot = (mjtNum*)d->act_dot; /* multi-activation user dynamics write act_dot */
  act_dot[adr + TENSIM_A_REST] = (next - rest) / dt;
  /* peak: the running maximum of the load-cell tension k max(0, x - l) */
  double stretch = x - (rest + act_dot[adr + TENSIM_A_REST] * dt);
  double spring = stretch > 0.0 ? k * stretch : 0.0;
  if (P(MODE) == TENSIM_MODE_PD) spring += pd_static(p, g, x, input); /* the load cell reads both */
  double peak = d->act[adr + TENSIM_A_PEAK];
  act_dot[adr + TENSIM_A_PEAK] = (fmax(peak, spring) - peak) / dt;
  /* the running maxima of the line speed |dl/dt| and of the power it takes, tension x speed */
  double speed = fabs(act_dot[adr + TENSIM_A_REST]), power = spring * speed;
  double peak_speed = d->act[adr + TENSIM_A_PEAK_SPEED];
  double peak_power = d->act[adr + TENSIM_A_PEAK_POWER];
  act_dot[adr + TENSIM_A_PEAK_SPEED] = (fmax(peak_speed, speed) - peak_speed) / dt;
  act_dot[adr + TENSIM_A_PEAK_POWER] = (fmax(peak_power, power) - peak_power) / dt;
  if (implicit) { /* pull: -theta while taut after the motor step, the gain term's input */
    int last = adr + m->actuator_actnum[i] - 1;
    double theta = m->opt.integrator == mjINT_IMPLICITFAST ? TENSIM_THETA_IMPLICITFAST
                                                           : TENSIM_THETA_DISCRETE;
    act_dot[last] = ((stretch > 0.0 ? -theta : 0.0) - d->act[last]) / dt;
  }
  return act_dot[adr + TENSIM_A_PEAK];
}

mjtNum tensim_act_bias(const mjModel* m, const mjData* d, int i) {
  double marker = cable_marker(m, i);
  if (marker == 0.0) return previous_bias ? previous_bias(m, d, i) : 0.0;
  if (marker == TENSIM_REFERENCE_MARKER) return reference_bias ? reference_bias(m, d, i) : NAN;
  const mjtNum* p = m->actuator_dynprm + i * mjNDYN;
  const mjtNum* g = m->actuator_gainprm + i * mjNGAIN;
  int tendon = m->actuator_trnid[2 * i];
  double x = d->ten_length[tendon], v = d->ten_velocity[tendon];
  /* cable (eq. 1-2): tension-only Hooke spring with linear damping, pulling the anchors in */
  double stretch = x - next_rest(m, d, i);
  double applied = stretch > 0.0 ? fmax(G(STIFFNESS) * stretch + G(DAMPING) * v, 0.0) : 0.0;
  /* a PD motor pulls beside the spring */
  if (P(MODE) == TENSIM_MODE_PD) applied += pd_applied(p, g, x, v, d->ctrl[m->actuator_ctrladr[i]]);
  double force = -applied;
  if (!implicit_law(m, i)) return force;
  /* implicit law: less MuJoCo's gain term (its arithmetic, on the pull as actearly reads it) */
  int last = m->actuator_actadr[i] + m->actuator_actnum[i] - 1;
  double pull = d->act[last] + d->act_dot[last] * m->opt.timestep;
  int out = m->actuator_outadr[i];
  double gain = g[0] + g[1] * d->actuator_length[out] + g[2] * d->actuator_velocity[out];
  return force - gain * pull;
}

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cable",
                             "Compiled tensim cable law (loaded through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__cable(void) { return PyModule_Create(&module); }
