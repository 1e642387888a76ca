"""Standard errors of a least-squares fit whose residuals are correlated and hold model error.

A simulated run's residuals stay correlated over many samples: a model error lasts as long
as the motion that shows it, hits every cable at once, and repeats with the gait. The
textbook s^2 (J^T J)^-1 counts every sample as independent and is then far too small, and on
a log of another model than the one fitted (a real robot) the fits on other windows of the
same log disagree by several of its standard errors. :func:`fit_stderr` therefore takes the
largest of three estimates and inflates it by the residuals' own correlation:

- :func:`naive_stderr`, s^2 (J^T J)^-1 (independent samples),
- :func:`row_stderr`, a sandwich clustered by sample time (all cables of one reading
  together: a model error moves them together),
- :func:`block_stderr`, a sandwich over contiguous time blocks (batch means),

times :func:`model_error_factor`, sqrt(1 + 2 sum |rho_l|) over the residuals'
autocorrelations rho_l at lags of 1 to half the samples (:func:`residual_correlation`): the
effective-sample-size factor of a correlated series, with magnitudes since a periodic model
error correlates negatively at half the gait's period and positively at the period. Sensor
noise leaves the sum near 0 and the factor near 1; a model error that the fitted model cannot
represent raises both, and more so the longer the window, as a bias shared by all its samples
does not shrink with their number. The variance this implies is about s^2 + 2 sum |gamma_l|
(the autocovariances): noise raises it through s^2, while the chance level subtracted from
each |rho_l| grows with the noise, so a much noisier log of the same model error claims about
the same interval as a clean one (within 10 % for ten times the noise in the tests), never
the much narrower one that treating the residuals as independent would give.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

LOG_STRIDE = 1_000_000_000  # a sample row's label: log index x LOG_STRIDE + row


def _bread(jac: np.ndarray) -> np.ndarray | None:
    try:
        return np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return None


def _sandwich(jac: np.ndarray, sums: np.ndarray, centre: bool) -> np.ndarray:
    """Standard errors (J^T J)^-1 S (J^T J)^-1 with S from the (k, n) score sums."""
    bread = _bread(jac)
    k = len(sums)
    if bread is None or k < 2:
        return np.full(jac.shape[1], np.inf)
    parts = sums - sums.mean(axis=0) if centre else sums
    meat = k / (k - 1) * parts.T @ parts
    variance = np.diag(bread @ meat @ bread)
    return np.where(variance >= 0, np.sqrt(np.abs(variance)), np.inf)


def _row_scores(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Labels of the sample rows and the (rows, n) sums of the scores J_i^T r_i per row."""
    labels, inverse = np.unique(rows, return_inverse=True)
    scores = np.zeros((labels.size, jac.shape[1]))
    np.add.at(scores, inverse, jac * residual[:, None])
    return labels, scores


def block_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray,
                 blocks: int = 5) -> np.ndarray:
    """Standard errors from the scatter of the score sums over contiguous time blocks.

    Each log's sample rows are cut into ``blocks`` contiguous time blocks; the sums of the
    scores J_i^T r_i over a block are nearly independent when a block is longer than the
    residuals' correlation, and the sandwich (J^T J)^-1 S (J^T J)^-1 takes S from their
    scatter (blocks / (blocks - 1) x the sum of their outer products, about their mean).

    Args:
        jac: (m, n) Jacobian of the residuals.
        residual: (m,) residuals at the solution.
        rows: (m,) label of each residual's sample row: log index x ``LOG_STRIDE`` + row.
        blocks: time blocks per log (>= 2).

    Returns:
        (n,) standard errors (inf: not determined).
    """
    labels, scores = _row_scores(jac, residual, rows)
    sums = []
    for log in np.unique(labels // LOG_STRIDE):
        own = scores[labels // LOG_STRIDE == log]
        sums += [part.sum(axis=0) for part in np.array_split(own, min(blocks, len(own)))]
    return _sandwich(jac, np.array(sums), centre=True)


def row_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Standard errors clustered by sample row: the residuals of one reading time (all its
    cables) may be correlated with each other, different times are taken as independent
    (arguments as :func:`block_stderr`)."""
    _, scores = _row_scores(jac, residual, rows)
    n = jac.shape[1]
    if len(scores) <= n:
        return np.full(n, np.inf)
    # the centred-about-zero cluster sandwich, with the small-sample factor T / (T - n)
    se = _sandwich(jac, scores, centre=False)
    return se * np.sqrt((len(scores) - 1) / (len(scores) - n))


def residual_correlation(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray
                         ) -> float:
    """How much the residuals' correlation over time inflates a variance [-, >= 0]:
    the sum over lags of 1 to half the rows of each lag's |autocorrelation| beyond what
    independent residuals would show by chance (1 / sqrt(pairs)).

    Per log and cable the residuals (less their mean) form a series over the sample rows;
    for each lag the products of samples that far apart are pooled over cables and logs and
    divided by the pooled variance. Magnitudes, not signed values, are summed: a periodic
    model error correlates negatively at half its period and positively at its period, and
    which of them a parameter's score follows is not known. Sensor noise adds to the
    variance only, so it lowers this sum about in proportion, and the variance it implies
    (:func:`model_error_factor`) stays about the same.

    Args:
        residual: (m,) residuals at the solution.
        rows: (m,) sample-row labels (:func:`block_stderr`).
        cables: (m,) index of each residual's cable.
    """
    grids = []
    for log in np.unique(rows // LOG_STRIDE):
        own = rows // LOG_STRIDE == log
        row = rows[own] % LOG_STRIDE
        row -= row.min()
        grid = np.full((int(row.max()) + 1, int(cables.max()) + 1), np.nan)
        grid[row, cables[own]] = residual[own]
        grids.append(grid - np.nanmean(grid, axis=0))
    variance = sum(float(np.nansum(g**2)) for g in grids)
    longest = max(len(g) for g in grids)
    if variance <= 0 or longest < 4:
        return 0.0
    total = 0.0
    for lag in range(1, longest // 2 + 1):
        products = [g[lag:] * g[:-lag] for g in grids if len(g) > lag]
        pairs = sum(int(np.isfinite(p).sum()) for p in products)
        if pairs:
            rho = abs(sum(float(np.nansum(p)) for p in products)) / variance
            total += max(rho - 1.0 / np.sqrt(pairs), 0.0)
    return total


def model_error_factor(correlation: float) -> float:
    """sqrt(1 + 2 x ``correlation``): the factor on the standard errors for residuals whose
    autocorrelations sum to ``correlation`` (the long-run variance of a correlated series
    over its variance: fewer independent samples than residuals)."""
    return float(np.sqrt(1.0 + 2.0 * max(correlation, 0.0)))


def interval_factor(blocks: int = 5, logs: int = 1) -> float:
    """Half-width of the 95 % interval in standard errors: Student's t with blocks x logs - 1
    degrees of freedom (the time-block estimate's; 2.78 for one log), the most cautious of
    the three estimates' small-sample quantiles."""
    return float(stats.t.ppf(0.975, max(blocks * logs - 1, 1)))


def naive_stderr(jac: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """s^2 (J^T J)^-1 with s^2 = RSS / (m - n): independent residuals assumed."""
    m, n = jac.shape
    if m <= n:
        return np.full(n, np.inf)
    bread = _bread(jac)
    if bread is None:
        return np.full(n, np.inf)
    variance = np.diag(float(residual @ residual) / (m - n) * bread)
    return np.where(variance >= 0, np.sqrt(np.abs(variance)), np.inf)


@dataclasses.dataclass(frozen=True)
class FitErrors:
    """The standard errors of a fit and the estimates they come from (unit coordinates of
    the Jacobian given).

    Attributes:
        stderr: (n,) reported: ``factor`` x the largest of the three estimates (inf: not
            determined).
        naive, row, block: (n,) :func:`naive_stderr`, :func:`row_stderr`,
            :func:`block_stderr`.
        correlation: :func:`residual_correlation` [-].
        factor: :func:`model_error_factor` of it [-].
    """

    stderr: np.ndarray
    naive: np.ndarray
    row: np.ndarray
    block: np.ndarray
    correlation: float
    factor: float


def fit_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
               blocks: int = 5) -> FitErrors:
    """The reported standard errors: the largest of the independent-sample, per-reading and
    time-block errors, times the model-error factor of the residuals' correlation
    (arguments as :func:`block_stderr` and :func:`residual_correlation`)."""
    naive = naive_stderr(jac, residual)
    row = row_stderr(jac, residual, rows)
    block = block_stderr(jac, residual, rows, blocks)
    correlation = residual_correlation(residual, rows, cables)
    factor = model_error_factor(correlation)
    return FitErrors(factor * np.maximum.reduce([naive, row, block]), naive, row, block,
                     correlation, factor)
