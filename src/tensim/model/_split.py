"""The implicit law's split by cable: which cables MuJoCo's ``discrete`` step is handed.

Under ``cable_law="implicit"`` each cable handed to the integrator is a coupling term of its
metric M + h D + h^2 K, and the step's cost grows with those terms (docs/speed.md). A cable
that the explicit law's step integrates well at the chosen step gains nothing from being handed
over, so ``WorldOptions.split_margin`` keeps such cables on the explicit law (an
implicit-explicit split by cable, chosen once, at the build pose, when the model is built).

The bound is the explicit law's (semi-implicit Euler) on the linearised motion of the cables
alone, M x'' = -J^T diag(k) J x - J^T diag(b) J x', with J the cables' tendon Jacobians and M
MuJoCo's mass matrix at the build pose. Its step matrix first grows through the eigenvalue -1,
at h = 2 / r for the largest real r with r^2 M x = J^T (diag(k) + r diag(b)) J x
(:func:`tensim.design.stiffness.step_bound` derives it). With y = J x that is the same problem
in the cables' coordinates, r^2 y = W (diag(k) + r diag(b)) y with W = J M^-1 J^T (the cables'
inverse effective masses), and with S = W^(1/2) a symmetric one, r^2 u = S (diag(k) + r
diag(b)) S u. One cable alone (w = W_cc) has the closed form r = (b w + sqrt((b w)^2 + 4 k w))
/ 2: a spring alone is stable below 2 / sqrt(k w), a damper alone below 2 / (b w).

The rule: cables in order of their own bound, the longest first, stay explicit as long as the
bound of all of them together is at least ``margin`` times the step (the bound of a set only
shortens as cables join it: adding stiffness or damping never lowers the largest root). The
cables' tension across their length (the geometric stiffness), which the explicit law keeps
explicit under every split, is left out; the margin covers it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from tensim.model._law_layout import G_DAMPING, G_PD_DAMPING, G_PD_STIFFNESS, G_STIFFNESS

# a margin at which the explicit law's step is accurate as well as stable on the robots of
# docs/speed.md (what `tensim bench --cable-laws` and `tensim experiment laws` run as the split)
MARGIN = 4.0


def inverse_effective_mass(model: mujoco.MjModel, data: mujoco.MjData,
                           tendons: np.ndarray) -> np.ndarray:
    """(n, n) W = J M^-1 J^T of ``tendons`` at ``data``'s pose (its kinematics, tendons and
    mass matrix computed): the lengthening rate each tendon's unit pull gives each tendon
    [1/kg]; its diagonal is each cable's own inverse effective mass."""
    jac = np.zeros((model.ntendon, model.nv))
    mujoco.mju_sparse2dense(jac, data.ten_J, model.ten_J_rownnz, model.ten_J_rowadr,
                            model.ten_J_colind)
    jac = jac[tendons]
    solved = np.zeros_like(jac)
    if len(jac):
        mujoco.mj_solveM(model, data, solved, jac)  # rows of (M^-1 J^T)^T
    inverse = jac @ solved.T
    return (inverse + inverse.T) / 2


def explicit_rate(inverse_mass: np.ndarray, stiffness: np.ndarray,
                  damping: np.ndarray) -> float:
    """The largest real r with r^2 u = S (diag(k) + r diag(b)) S u, S = W^(1/2) (0 where
    nothing springs or damps): the explicit step is stable below 2 / r [s].

    Args:
        inverse_mass: (n, n) W = J M^-1 J^T [1/kg].
        stiffness: (n,) k [N/m].
        damping: (n,) b [N s/m].
    """
    n = len(stiffness)
    if not n:
        return 0.0
    values, vectors = np.linalg.eigh(inverse_mass)
    root = (vectors * np.sqrt(np.clip(values, 0.0, None))) @ vectors.T  # S, symmetric
    if n == 1:
        kw, bw = stiffness[0] * root[0, 0] ** 2, damping[0] * root[0, 0] ** 2
        return float((bw + np.sqrt(bw * bw + 4 * kw)) / 2)
    stiff, rate = (root * stiffness) @ root, (root * damping) @ root
    # the companion matrix [[0, I], [S K S, S B S]] has the eigenvalue r for (u, r u)
    companion = np.block([[np.zeros((n, n)), np.eye(n)], [stiff, rate]])
    roots = np.linalg.eigvals(companion)
    size = max(float(np.abs(roots).max()), 1e-300)
    real = roots.real[(np.abs(roots.imag) <= 1e-9 * size) & (roots.real > 1e-12 * size)]
    return float(real.max()) if real.size else 0.0


def own_bounds(inverse_mass: np.ndarray, stiffness: np.ndarray, damping: np.ndarray
               ) -> np.ndarray:
    """(n,) each cable's own explicit step bound [s]: 2 / r with r = (b w + sqrt((b w)^2 +
    4 k w)) / 2, w its inverse effective mass (inf where nothing springs or damps)."""
    w = np.clip(np.diag(inverse_mass), 0.0, None)
    kw, bw = stiffness * w, damping * w
    rate = (bw + np.sqrt(bw * bw + 4 * kw)) / 2
    with np.errstate(divide="ignore"):
        return np.where(rate > 0, 2 / np.where(rate > 0, rate, 1.0), np.inf)


def explicit_cables(inverse_mass: np.ndarray, stiffness: np.ndarray, damping: np.ndarray,
                    timestep: float, margin: float) -> np.ndarray:
    """(n,) which cables stay on the explicit law: in order of their own bound, the longest
    first, as many as keep the explicit bound of them all together at least ``margin`` x
    ``timestep`` (none where ``margin`` is 0).

    Args:
        inverse_mass: (n, n) W = J M^-1 J^T of the cables [1/kg].
        stiffness: (n,) k [N/m].
        damping: (n,) b [N s/m].
        timestep: the step [s].
        margin: the least bound, in steps [-].
    """
    n = len(stiffness)
    keep = np.zeros(n, dtype=bool)
    if margin <= 0 or not n:
        return keep
    order = np.argsort(-own_bounds(inverse_mass, stiffness, damping), kind="stable")
    need = 2 / (margin * timestep)  # the largest rate r the set may have

    def fits(count: int) -> bool:
        chosen = order[:count]
        return explicit_rate(inverse_mass[np.ix_(chosen, chosen)], stiffness[chosen],
                             damping[chosen]) <= need

    low, high = 0, n  # fits(low); the bound only shortens as cables join: bisect the count
    if fits(n):
        low = n
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    keep[order[:low]] = True
    return keep


def cable_terms(model: mujoco.MjModel, keyframe: int, actuators: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(W [1/kg], k [N/m], b [N s/m]) of the cable ``actuators`` at ``model``'s keyframe: W =
    J M^-1 J^T of their tendons, and each cable's stiffness and damping (a PD motor's servo
    counts with its cable's spring, as engaged)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, keyframe)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_crb(model, data)
    mujoco.mj_factorM(model, data)
    mujoco.mj_tendon(model, data)
    gain = model.actuator_gainprm[actuators]
    stiffness = gain[:, G_STIFFNESS] + gain[:, G_PD_STIFFNESS]
    damping = gain[:, G_DAMPING] + gain[:, G_PD_DAMPING]
    inverse = inverse_effective_mass(model, data, model.actuator_trnid[actuators, 0])
    return inverse, stiffness, damping


def split_cables(model: mujoco.MjModel, keyframe: int, actuators: np.ndarray, timestep: float,
                 margin: float) -> np.ndarray:
    """(n,) which of the cable ``actuators`` stay on the explicit law at ``model``'s keyframe
    (:func:`explicit_cables` on :func:`cable_terms`)."""
    return explicit_cables(*cable_terms(model, keyframe, actuators), timestep, margin)
