"""Standard errors of a least-squares fit whose residuals are correlated in time.

A simulated run's residuals stay correlated over many samples: a model error lasts as long
as the motion that shows it. The textbook s^2 (J^T J)^-1 counts every sample as independent
and is then far too small; :func:`block_stderr` takes the scatter of the scores over
contiguous time blocks instead (a batch-means / cluster-robust sandwich), and
:func:`interval_factor` the Student-t quantile for its few degrees of freedom.
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def block_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray,
                 blocks: int = 5) -> np.ndarray:
    """Standard errors of a least-squares fit whose residuals are correlated in time.

    A simulated run's residuals stay correlated over many samples (a model error lasts as
    long as the motion that shows it), so s^2 (J^T J)^-1, which counts every sample as
    independent, is far too small. Here each log's sample rows are cut into ``blocks``
    contiguous time blocks; the sums of the scores J_i^T r_i over a block are nearly
    independent, and the sandwich (J^T J)^-1 S (J^T J)^-1 takes S from their scatter
    (blocks / (blocks - 1) x the sum of their outer products, about their mean). Intervals
    use Student's t with ``blocks - 1`` degrees of freedom (:func:`interval_factor`).

    Args:
        jac: (m, n) Jacobian of the residuals.
        residual: (m,) residuals at the solution.
        rows: (m,) label of each residual's sample row: log index x 1e9 + row.
        blocks: time blocks per log (>= 2).

    Returns:
        (n,) standard errors (inf: not determined).
    """
    labels, inverse = np.unique(rows, return_inverse=True)
    scores = np.zeros((labels.size, jac.shape[1]))
    np.add.at(scores, inverse, jac * residual[:, None])
    sums = []
    for log in np.unique(labels // 1_000_000_000):
        own = scores[labels // 1_000_000_000 == log]
        sums += [part.sum(axis=0) for part in np.array_split(own, min(blocks, len(own)))]
    if len(sums) < 2:
        return np.full(jac.shape[1], np.inf)
    centred = np.array(sums) - np.mean(sums, axis=0)
    meat = len(sums) / (len(sums) - 1) * centred.T @ centred
    try:
        bread = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.inf)
    variance = np.diag(bread @ meat @ bread)
    return np.where(variance >= 0, np.sqrt(np.abs(variance)), np.inf)


def interval_factor(blocks: int = 5, logs: int = 1) -> float:
    """Half-width of the 95 % interval in standard errors: Student's t, blocks x logs - 1 dof."""
    return float(stats.t.ppf(0.975, max(blocks * logs - 1, 1)))


def naive_stderr(jac: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """s^2 (J^T J)^-1 with s^2 = RSS / (m - n): independent residuals assumed."""
    m, n = jac.shape
    if m <= n:
        return np.full(n, np.inf)
    try:
        covariance = float(residual @ residual) / (m - n) * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(n, np.inf)
    variance = np.diag(covariance)
    return np.where(variance >= 0, np.sqrt(np.abs(variance)), np.inf)
