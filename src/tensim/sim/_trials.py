"""A batch's trials: what each one runs, how its own model copy is set up, what it returns.

Shared by the back-ends of :func:`tensim.sim.run_batch` (MuJoCo's batch engine on threads,
MuJoCo Warp's worlds).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import mujoco
import numpy as np

from tensim.model import CompiledModel, ModelIndex
from tensim.model import _law_layout as layout
from tensim.sim._drive import CableDrive, InputPlan
from tensim.sim._loads import NodeLoad
from tensim.sim._samples import SampleBuffers, sample_channels
from tensim.sim._simulation import Controller, SimulationResult

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclasses.dataclass(frozen=True)
class PhysicsScale:
    """Multipliers on a trial's physical parameters (1 leaves one as built).

    Attributes:
        friction: sliding friction of every robot geom.
        stiffness: every cable's stiffness k.
        damping: every cable's damping b.
        mass: every rigid body's mass and inertia (rods and point masses alike).
        motor_speed: every motor's maximum speed (a DC motor's no-load speed).
        motor_stall: every DC motor's stall torque.
        motor_inertia: every DC motor's rotor inertia.
        motor_friction: every DC motor's viscous and Coulomb friction.
    """

    friction: float = 1.0
    stiffness: float = 1.0
    damping: float = 1.0
    mass: float = 1.0
    motor_speed: float = 1.0
    motor_stall: float = 1.0
    motor_inertia: float = 1.0
    motor_friction: float = 1.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"physics scale {f.name} must be a finite number > 0, "
                                 f"got {value!r}")


@dataclasses.dataclass(frozen=True)
class Trial:
    """One run of a batch.

    Attributes:
        controller: sets up the cable drive (None: rest lengths held).
        loads: external node forces.
        initial_state: ``Simulation.get_state()`` of the same model to start from (None: the
            build pose, with the motor update at t = 0 taken first, as a new Simulation does).
        physics: per-trial physical parameters (multipliers).
        compiled: the trial's own model, e.g. a structure with other parameters recompiled
            (None: the batch's); it must have the batch model's layout (same sizes).
    """

    controller: Controller | None = None
    loads: tuple[NodeLoad, ...] = ()
    initial_state: np.ndarray | None = None
    physics: PhysicsScale = PhysicsScale()
    compiled: CompiledModel | None = None


@dataclasses.dataclass(frozen=True)
class TrialResult:
    """A trial's outcome: its run, or why it failed.

    Attributes:
        result: the finished run (None if it failed).
        error: what went wrong (None if it finished).
    """

    result: SimulationResult | None
    error: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the trial ran to the end."""
        return self.result is not None


@dataclasses.dataclass
class _TrialSetup:
    """What a controller configures for one trial (the attributes a Simulation offers it)."""

    compiled: CompiledModel
    drive: CableDrive
    dt: float

    @property
    def index(self) -> ModelIndex:
        """The model's names and ids."""
        return self.compiled.index


def setup_trial(compiled: CompiledModel, model: mujoco.MjModel, trial: Trial,
                dt: float) -> InputPlan:
    """Sets up one trial on its own model copy: physics multipliers, then its controller's
    gains; returns its inputs.

    Raises:
        ValueError, KeyError, TypeError: the trial cannot run (the message says why).
    """
    drive = CableDrive(compiled, model)
    scale(compiled, model, trial.physics)
    if trial.controller is not None:
        trial.controller.configure(_TrialSetup(compiled, drive, dt))
    check_law(compiled, model)
    if trial.initial_state is not None:
        check_state(model, trial.initial_state)
    return InputPlan(drive, trial.loads, compiled)


def check_law(compiled: CompiledModel, model: mujoco.MjModel) -> None:
    """Refuses a trial's model whose cable law parameters (as its controller left them) are
    not all finite.

    Raises:
        ValueError: naming the first such cable.
    """
    n = compiled.n_cables
    bad = ~np.isfinite(model.actuator_dynprm[:n]).all(axis=1) | \
        ~np.isfinite(model.actuator_biasprm[:n]).all(axis=1) | \
        ~np.isfinite(model.actuator_gainprm[:n]).all(axis=1)
    if bad.any():
        raise ValueError(f"cable {compiled.index.cables[int(np.argmax(bad))]!r} has "
                         "non-finite law parameters")


def trial_results(samples: SampleBuffers, count: np.ndarray, models: Sequence[mujoco.MjModel],
                  errors: Sequence[str | None], peaks: np.ndarray, index: ModelIndex, dt: float,
                  duration: float, wall: float) -> list[TrialResult]:
    """Each trial's recorded run (channels derived with its own model's parameters), or its
    error; ``peaks``: (n_trials, 3, n_cables) the peak tensions [N], line speeds [m/s] and
    powers [W] (:meth:`ModelIndex.cable_peaks`)."""
    n = len(index.cables)
    out = []
    for i, model in enumerate(models):
        if errors[i] is not None:
            out.append(TrialResult(None, errors[i]))
            continue
        series = sample_channels(samples.trial(i).head(int(count[i])), index,
                                 model.actuator_dynprm[:n], model.actuator_gainprm[:n])
        # wall_s: the trial's share of the batch's wall time
        tension, speed, power = np.array(peaks[i], dtype=float)
        out.append(TrialResult(SimulationResult(series, tension, wall / len(models), duration,
                                                dt, index.cables, speed, power)))
    return out


def trial_models(compiled: CompiledModel, trials: Sequence[Trial]) -> list[CompiledModel]:
    """Each trial's compiled model, all with the force inputs that any trial's loads need."""
    nodes = tuple(dict.fromkeys(ld.node for t in trials for ld in t.loads))
    done: dict[int, CompiledModel] = {}
    out = []
    for trial in trials:
        own = trial.compiled or compiled
        if id(own) not in done:
            done[id(own)] = own.with_load_nodes(nodes)
        out.append(done[id(own)])
    return out


def scale(compiled: CompiledModel, model: mujoco.MjModel, physics: PhysicsScale) -> None:
    """Applies a trial's physics multipliers to its own model copy."""
    if physics == PhysicsScale():
        return
    n = compiled.n_cables
    model.geom_friction[model.geom_bodyid != 0, 0] *= physics.friction
    model.actuator_gainprm[:n, layout.G_STIFFNESS] *= physics.stiffness
    model.actuator_gainprm[:n, layout.G_DAMPING] *= physics.damping
    model.actuator_dynprm[:n, layout.P_MAX_SPEED] *= physics.motor_speed
    # DC motors (kinematic motors hold zeros in these slots)
    dc = model.actuator_biasprm[:n]
    dc[:, layout.B_NO_LOAD_SPEED] *= physics.motor_speed
    dc[:, layout.B_STALL_FORCE] *= physics.motor_stall
    dc[:, layout.B_MASS] *= physics.motor_inertia
    dc[:, [layout.B_VISCOUS, layout.B_COULOMB]] *= physics.motor_friction
    if physics.mass != 1.0:
        model.body_mass[1:] *= physics.mass
        model.body_inertia[1:] *= physics.mass
        mujoco.mj_setConst(model, mujoco.MjData(model))  # the constants derived from masses


def check_state(model: mujoco.MjModel, state: np.ndarray) -> None:
    """Refuses an initial state of the wrong size or with non-finite values (ValueError)."""
    size = mujoco.mj_stateSize(model, _STATE)
    if np.shape(state) != (size,):
        raise ValueError(f"initial_state must have {size} values (mjSTATE_INTEGRATION of this "
                         f"model), got shape {np.shape(state)}")
    if not np.all(np.isfinite(state)):
        raise ValueError("initial_state holds non-finite values")
