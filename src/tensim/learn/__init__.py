"""Learning gaits: problems, ask/tell optimizers, parallel trials and resumable run folders.

``learn(problem, settings, out)`` searches a controller family's parameter vector for the best
score of a simulated trial; ``resume(out)`` continues an interrupted or finished run. The
command line is ``tensim learn``.
"""

from tensim.learn.executors import (
    ClusterError,
    InlineExecutor,
    ProcessPoolExecutor,
    RayExecutor,
    make_executor,
)
from tensim.learn.families import FAMILIES, default_base, gait_layout
from tensim.learn.nelder_mead import NelderMead
from tensim.learn.objective import Objective, parse_direction
from tensim.learn.optimizers import CMAES, OPTIMIZERS, NTRTSearch, OptimizerSettings
from tensim.learn.problem import Evaluation, Outcome, SphereProblem, TrialProblem
from tensim.learn.run import LearningSettings, create_run, discard_unstarted, learn, resume
from tensim.learn.store import RunFolderError, RunStore

__all__ = [
    "CMAES",
    "FAMILIES",
    "OPTIMIZERS",
    "ClusterError",
    "Evaluation",
    "InlineExecutor",
    "LearningSettings",
    "NTRTSearch",
    "NelderMead",
    "Objective",
    "OptimizerSettings",
    "Outcome",
    "ProcessPoolExecutor",
    "RayExecutor",
    "RunFolderError",
    "RunStore",
    "SphereProblem",
    "TrialProblem",
    "create_run",
    "default_base",
    "discard_unstarted",
    "gait_layout",
    "learn",
    "make_executor",
    "parse_direction",
    "resume",
]
