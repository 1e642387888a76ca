/* Compiled record loop of one simulation: the records of tensim.sim._loop.record_loop that
 * need no Python, stepped and sampled in one call.
 *
 * Per record it does what tensim.sim._simulation's Python back-end does, in the same order:
 * the record's physics steps, one mj_step per step on each run of equal ctrl rows of the
 * input block (_Segments.run); on a watched record (tensim.sim._loop.watched) the last
 * RING_STEPS steps one call each, the cable forces after each kept in the ringing check's
 * history (ForceHistory.push); one gather of the sampled MjData values into the record's row
 * (SampleRows.take); and on a record the loop checks after, Simulation.check's tests: the
 * stability bounds (tensim.sim._loop.stable), the peak tensions kept for a later message, and
 * after forces were pushed the ringing test and the energy's. Those two are tested here only
 * for the common case, that nothing rings (no cable passes ringing's first test) and the
 * energy's excess is below its limit by a margin far above rounding; the fields of each
 * energy check go back to Python, which computes the exact energies for the run's history
 * (the values NumPy gives, which the check's later verdicts compare). It returns to Python at
 * the end of the stretch asked for, when that buffer is full, and after a check record whose
 * check needs Python: a state out of bounds, a cable that may ring, an energy near its limit,
 * or a contact check (Python's check then decides and names what ran away).
 *
 * mj_step is MuJoCo's own, from the library the Python bindings loaded (its address is given).
 * A MuJoCo error inside it comes to this library's handler (installed as mju_user_error; the
 * bindings' own thread-local handler takes precedence over it for their calls), which jumps
 * back out of the call with the message, so Python raises it as the bindings would.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#define TENSIM_RECORD_VERSION 3

typedef void (*StepFn)(const mjModel*, mjData*);
typedef void (*ErrorFn)(const char*);

/* What stays the same through a run (RecordSpec in _record_native.py). */
typedef struct {
  StepFn step;
  ErrorFn* user_error;        /* MuJoCo's mju_user_error */
  const mjModel* m;
  mjData* d;
  int nstep;                  /* physics steps per record */
  int n_samples;              /* records of the run */
  int check_every, ring_every, ring_steps;
  int python_checks;          /* every check record goes to Python (contact cables) */
  /* samples: rows[k, j] = flat[columns[j]], times[k] = d->time */
  const mjtNum* flat;
  const long long* columns;
  int ncolumns;
  mjtNum* rows;
  mjtNum* times;
  /* stability bounds and what a check keeps */
  int n_cables;
  mjtNum max_speed, max_tension;
  const long long* peak_act;  /* each cable's peak-tension slot in act */
  mjtNum* peak_seen;          /* (n_cables) the peaks at the last passed check */
  mjtNum* force;              /* ForceHistory's (ring_steps, n_cables) forces, oldest first */
  long long* count;           /* ... and its count of pushes */
  const mjtNum* ring_floor;   /* (n_cables) the change a ringing cable passes (ringing's) */
  /* the energy (tensim.sim._loop.Energy.total's terms) and the run's limit on its excess */
  int n_lin;
  const long long* lin;       /* (n_lin) translational dofs */
  const mjtNum* lin_mass;     /* (n_lin) half their masses */
  int n_free;
  const long long* ang;       /* (3 n_free) rotational dofs */
  const mjtNum* inertia;      /* (n_free, 3, 3) half the free bodies' inertias */
  const long long* body;      /* (n_free) the free bodies */
  const mjtNum* mass;         /* (n_free) their masses */
  const mjtNum* gravity;      /* (3) */
  const long long* tendon;    /* (n_cables) each cable's tendon */
  const long long* rest;      /* (n_cables) its rest length's slot in act */
  const mjtNum* stiffness;    /* (n_cables) half its stiffness */
  mjtNum limit;               /* EnergyHistory.limit */
  /* the fields of each energy check, for Python's exact energies: time, qvel, xpos,
   * ten_length, act */
  mjtNum* snapshots;
  int snapshot_size, snapshot_capacity;
} RecordSpec;

/* Where a run is, and what a call left for Python (RecordCursor in _record_native.py). */
typedef struct {
  long long k;                /* the next record */
  long long sample;           /* the next sample row */
  const mjtNum* control;      /* the input block's ctrl rows (rows x nu) */
  const long long* cuts;      /* ends of its runs of equal rows, ascending, the last = rows */
  int nu;
  long long done;             /* the block's rows stepped */
  long long cut;              /* the run the next step is in */
  int pushed;                 /* forces pushed since Python's last ringing test */
  int checked;                /* a check passed here: peak_seen and peak_time are new */
  mjtNum peak_time;           /* data time at that check */
  mjtNum lowest;              /* the run's lowest energy so far (EnergyHistory.lowest) */
  int snapshots;              /* energy checks passed here, their fields in snapshots */
  char error[1024];           /* MuJoCo's error message (status -1) */
} RecordCursor;

enum { REACHED = 0, CHECK = 1, FAILED = -1, NO_HANDLER = -2 };

static _Thread_local jmp_buf* jump = NULL;
static _Thread_local char message[1024];

/* mju_user_error: back out of the compiled loop with the message; anywhere else (a raw call
 * outside the bindings, which would otherwise meet MuJoCo's default), MuJoCo's default. */
static void on_error(const char* msg) {
  if (jump != NULL) {
    strncpy(message, msg, sizeof(message) - 1);
    message[sizeof(message) - 1] = '\0';
    longjmp(*jump, 1);
  }
  printf("ERROR: %s\n", msg);
  fflush(stdout);
  exit(EXIT_FAILURE);
}

int tensim_record_version(void) { return TENSIM_RECORD_VERSION; }
/* The MuJoCo this library was built against: its mjModel and mjData layouts are read here. */
int tensim_record_header_version(void) { return mjVERSION_HEADER; }
int tensim_record_spec_size(void) { return (int)sizeof(RecordSpec); }
int tensim_record_cursor_size(void) { return (int)sizeof(RecordCursor); }
void* tensim_record_handler(void) { return (void*)on_error; }

/* Steps `count` rows of the block, one mj_step per step, ctrl set at each run of equal rows. */
static void steps(const RecordSpec* s, RecordCursor* c, long long count) {
  long long stop = c->done + count;
  while (c->done < stop) {
    while (c->cuts[c->cut] <= c->done) c->cut++;
    long long end = c->cuts[c->cut] < stop ? c->cuts[c->cut] : stop;
    memcpy(s->d->ctrl, c->control + c->done * c->nu, sizeof(mjtNum) * c->nu);
    for (long long j = c->done; j < end; j++) s->step(s->m, s->d);
    c->done = end;
  }
}

/* ForceHistory.push: the cable forces of the step just taken. */
static void push(const RecordSpec* s, RecordCursor* c) {
  int n = s->n_cables;
  if (s->ring_steps > 1)
    memmove(s->force, s->force + n, sizeof(mjtNum) * n * (s->ring_steps - 1));
  memcpy(s->force + (long long)n * (s->ring_steps - 1), s->d->actuator_force,
         sizeof(mjtNum) * n);
  (*s->count)++;
  c->pushed = 1;
}

/* tensim.sim._loop.stable for one world: NaN fails every comparison, as there. */
static int stable(const RecordSpec* s) {
  const mjData* d = s->d;
  if (!(0.0 < s->max_speed) || !(0.0 < s->max_tension)) return 0;
  for (int i = 0; i < s->m->nv; i++)
    if (!(fabs(d->qvel[i]) < s->max_speed)) return 0;
  for (int i = 0; i < s->n_cables; i++)
    if (!(-d->actuator_force[i] < s->max_tension)) return 0;
  return d->warning[mjWARN_BADQACC].number == 0;
}

/* Whether a cable might ring (tensim.sim._loop.ringing's first test, which every ringing
 * cable passes; NaN passes none, as there): Python's test then decides. */
static int may_ring(const RecordSpec* s) {
  int n = s->n_cables;
  const mjtNum *f0 = s->force, *f1 = f0 + n, *f2 = f1 + n;
  for (int i = 0; i < n; i++)
    if (fabs(f1[i] - f0[i]) > s->ring_floor[i] && fabs(f2[i] - f1[i]) > s->ring_floor[i])
      return 1;
  return 0;
}

/* Whether the energy check cannot fire here: the excess over the lowest energy, computed in
 * another order than NumPy's (so differing from Python's by rounding, far inside the margin),
 * is below the limit by the margin, the energy finite. The lowest energy then follows it. */
static int energy_low(const RecordSpec* s, RecordCursor* c, mjtNum* size) {
  const mjData* d = s->d;
  mjtNum total = 0, magnitude = 0;
  for (int i = 0; i < s->n_lin; i++) {
    mjtNum v = d->qvel[s->lin[i]];
    total += v * v * s->lin_mass[i];
  }
  magnitude = total;
  for (int k = 0; k < s->n_free; k++) {
    const mjtNum* w0 = d->qvel;
    mjtNum w[3] = {w0[s->ang[3 * k]], w0[s->ang[3 * k + 1]], w0[s->ang[3 * k + 2]]};
    const mjtNum* in = s->inertia + 9 * k;
    mjtNum term = 0;
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) term += w[i] * in[3 * i + j] * w[j];
    total += term;
    magnitude += fabs(term);
    const mjtNum* x = d->xpos + 3 * s->body[k];
    mjtNum height = (x[0] * s->gravity[0] + x[1] * s->gravity[1] + x[2] * s->gravity[2]) *
                    s->mass[k];
    total -= height;
    magnitude += fabs(height);
  }
  for (int i = 0; i < s->n_cables; i++) {
    mjtNum stretch = d->ten_length[s->tendon[i]] - d->act[s->rest[i]];
    if (stretch > 0) {
      total += stretch * stretch * s->stiffness[i];
      magnitude += stretch * stretch * s->stiffness[i];
    }
  }
  if (!isfinite(total) || !isfinite(magnitude)) return 0;
  mjtNum lowest = c->lowest < total ? c->lowest : total;
  if (*size < magnitude) *size = magnitude;
  if (!(total - lowest <= s->limit - 1e-9 * (*size + fabs(lowest)))) return 0;
  c->lowest = lowest;
  return 1;
}

/* Keeps the fields of an energy check passed in C, for Python's exact energy history. */
static void snapshot(const RecordSpec* s, RecordCursor* c) {
  const mjModel* m = s->m;
  const mjData* d = s->d;
  mjtNum* out = s->snapshots + (long long)c->snapshots * s->snapshot_size;
  *out++ = d->time;
  memcpy(out, d->qvel, sizeof(mjtNum) * m->nv);
  out += m->nv;
  memcpy(out, d->xpos, sizeof(mjtNum) * 3 * m->nbody);
  out += 3 * m->nbody;
  memcpy(out, d->ten_length, sizeof(mjtNum) * m->ntendon);
  out += m->ntendon;
  memcpy(out, d->act, sizeof(mjtNum) * m->na);
  c->snapshots++;
}

/* One record: its steps (the last ones one call each where watched), then its sample. */
static void record(const RecordSpec* s, RecordCursor* c) {
  long long k = c->k;
  int nstep = s->nstep, ring = s->ring_steps;
  int watched = nstep < ring || k % ((long long)s->check_every * s->ring_every) == 0 ||
                k == s->n_samples - 1;
  if (!watched) {
    steps(s, c, nstep);
  } else if (nstep - (ring - 1) > 1) {  /* tensim.sim._loop.split_steps */
    steps(s, c, nstep - (ring - 1));
    push(s, c);
    for (int j = 0; j < ring - 1; j++) {
      steps(s, c, 1);
      push(s, c);
    }
  } else {
    for (int j = 0; j < nstep; j++) {
      steps(s, c, 1);
      push(s, c);
    }
  }
  mjtNum* row = s->rows + c->sample * (long long)s->ncolumns;
  for (int j = 0; j < s->ncolumns; j++) row[j] = s->flat[s->columns[j]];
  s->times[c->sample] = s->d->time;
  c->sample++;
  c->k++;
}

/* Runs records cursor->k .. stop - 1, the block's rows permitting; returns REACHED at stop,
 * CHECK after a check record Python must check (cursor->k is the record after it), FAILED on
 * a MuJoCo error (cursor->error), NO_HANDLER when mju_user_error is not this library's. */
int tensim_records(const RecordSpec* s, RecordCursor* c, long long stop) {
  if (*s->user_error != on_error) return NO_HANDLER;
  jmp_buf here;
  jmp_buf* outer = jump;
  if (setjmp(here)) {
    jump = outer;
    strncpy(c->error, message, sizeof(c->error) - 1);
    c->error[sizeof(c->error) - 1] = '\0';
    return FAILED;
  }
  jump = &here;
  int status = REACHED;
  mjtNum size = 0;
  c->checked = 0;
  c->snapshots = 0;
  while (c->k < stop && c->snapshots < s->snapshot_capacity) {
    long long k = c->k;
    record(s, c);
    if (k % s->check_every == 0 || k == s->n_samples - 1) {
      /* Simulation.check: the bounds, then where forces were pushed ringing and energy */
      if (s->python_checks || !stable(s) ||
          (c->pushed && (may_ring(s) || !energy_low(s, c, &size)))) {
        status = CHECK;
        break;
      }
      for (int i = 0; i < s->n_cables; i++) s->peak_seen[i] = s->d->act[s->peak_act[i]];
      c->peak_time = s->d->time;
      c->checked = 1;
      if (c->pushed) {
        snapshot(s, c);
        c->pushed = 0;
      }
    }
  }
  jump = outer;
  return status;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_record", NULL, -1, NULL};
PyMODINIT_FUNC PyInit__record(void) { return PyModule_Create(&module); }
