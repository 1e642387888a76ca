"""Standard errors of a least-squares fit whose residuals are correlated and hold model error.

A simulated run's residuals stay correlated over many samples: a model error lasts as long
as the motion that shows it, hits every cable at once, and repeats with the gait. The
textbook s^2 (J^T J)^-1 counts every sample as independent and is then far too small, and on
a log of another model than the one fitted (a real robot) the fits on other windows of the
same log disagree by several of its standard errors. :func:`fit_stderr` counts the samples
once, by one effective sample size:

- the per-sample error is the larger of :func:`naive_stderr`, s^2 (J^T J)^-1, and
  :func:`row_stderr`, a sandwich clustered by sample time (all cables of one reading
  together: a model error moves them together); neither counts correlation in time;
- :func:`correlation_time` is the residuals' integrated autocorrelation time in seconds,
  tau = dt (1/2 + sum |rho_l|) over the lags l of each log's own sample period dt, summed up
  to Sokal's self-consistent window (the first lag of at least 5 tau, or half the samples):
  magnitudes, since a periodic model error correlates negatively at half the gait's period
  and positively at the period, and which of them a parameter's score follows is not known;
- :func:`effective_samples` is n_eff = T / (2 tau) per log of duration T = samples x dt,
  summed over the logs, and the errors are multiplied by sqrt(samples / n_eff).

The same motion logged at another rate has the same correlation time in seconds, so the same
n_eff and about the same interval. Sensor noise adds to s^2 and shortens tau about in
proportion, so the variance it implies, about s^2 tau, does not fall with it. A model error
that the fitted model cannot represent correlates over the whole window (tau of a fraction of
the gait's period and more) and leaves only a few effective samples, so the interval also
holds a bias that every sample shares, which the scatter of the samples does not show.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

LOG_STRIDE = 1_000_000_000  # a sample row's label: log index x LOG_STRIDE + row
SOKAL_WINDOW = 5.0  # the sum of |rho| stops at the first lag of at least this many tau


def _bread(jac: np.ndarray) -> np.ndarray | None:
    try:
        return np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return None


def _sandwich(jac: np.ndarray, sums: np.ndarray) -> np.ndarray:
    """Standard errors (J^T J)^-1 S (J^T J)^-1 with S from the (k, n) score sums."""
    bread = _bread(jac)
    k = len(sums)
    if bread is None or k < 2:
        return np.full(jac.shape[1], np.inf)
    meat = k / (k - 1) * sums.T @ sums
    variance = np.diag(bread @ meat @ bread)
    return np.where(variance >= 0, np.sqrt(np.abs(variance)), np.inf)


def _row_scores(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Labels of the sample rows and the (rows, n) sums of the scores J_i^T r_i per row."""
    labels, inverse = np.unique(rows, return_inverse=True)
    scores = np.zeros((labels.size, jac.shape[1]))
    np.add.at(scores, inverse, jac * residual[:, None])
    return labels, scores


def row_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Standard errors clustered by sample row: the residuals of one reading time (all its
    cables) may be correlated with each other, different times are taken as independent.

    Args:
        jac: (m, n) Jacobian of the residuals.
        residual: (m,) residuals at the solution.
        rows: (m,) label of each residual's sample row: log index x ``LOG_STRIDE`` + row.

    Returns:
        (n,) standard errors (inf: not determined).
    """
    _, scores = _row_scores(jac, residual, rows)
    n = jac.shape[1]
    if len(scores) <= n:
        return np.full(n, np.inf)
    # the centred-about-zero cluster sandwich, with the small-sample factor T / (T - n)
    se = _sandwich(jac, scores)
    return se * np.sqrt((len(scores) - 1) / (len(scores) - n))


def _grid(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray) -> np.ndarray:
    """(samples, cables) residuals of one log less each cable's mean (NaN: no sample)."""
    row = rows % LOG_STRIDE
    row = row - row.min()
    grid = np.full((int(row.max()) + 1, int(cables.max()) + 1), np.nan)
    grid[row, cables] = residual
    return grid - np.nanmean(grid, axis=0)


def _sokal_sum(rho: np.ndarray) -> float:
    """sum |rho_l| for l = 1..M, M the first lag with M >= SOKAL_WINDOW (1/2 + that sum)."""
    total = 0.0
    for lag, value in enumerate(np.abs(rho), start=1):
        total += float(value)
        if lag >= SOKAL_WINDOW * (0.5 + total):
            break
    return total


def correlation_time(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
                     period: float) -> float:
    """The residuals' integrated autocorrelation time [s] in one log sampled every ``period``.

    Per cable the residuals (less their mean) form a series over the sample rows; for each
    lag the products of samples that far apart are pooled over cables and divided by the
    pooled variance (rho_l). tau = period (1/2 + sum |rho_l|), the sum over lags 1..M with
    Sokal's window M (the first lag of at least 5 tau; at most half the samples). Independent
    residuals give tau of about half a period.

    Args:
        residual: (m,) residuals of one log.
        rows: (m,) their sample-row labels (:func:`row_stderr`).
        cables: (m,) index of each residual's cable.
        period: time between the log's sample rows [s].
    """
    grid = _grid(residual, rows, cables)
    variance = float(np.nansum(grid**2))
    if variance <= 0 or len(grid) < 4:
        return 0.5 * period
    rho = np.array([float(np.nansum(grid[lag:] * grid[:-lag])) / variance
                    for lag in range(1, len(grid) // 2 + 1)])
    return period * (0.5 + _sokal_sum(rho))


def effective_samples(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
                      periods: np.ndarray) -> tuple[float, float, list[float]]:
    """Sample rows, effective independent samples (n_eff = T / (2 tau) per log of duration
    T = rows x period, summed) and each log's correlation time [s].

    Args:
        residual, rows, cables: as :func:`correlation_time`, all logs.
        periods: (logs,) each log's time between sample rows [s].
    """
    samples, effective, taus = 0.0, 0.0, []
    for log in np.unique(rows // LOG_STRIDE):
        own = rows // LOG_STRIDE == log
        count = np.unique(rows[own]).size
        tau = correlation_time(residual[own], rows[own], cables[own], float(periods[log]))
        samples += count
        effective += min(count * periods[log] / (2.0 * tau), count)
        taus.append(tau)
    return samples, effective, taus


def interval_factor(logs: int = 1) -> float:
    """Half-width of the 95 % interval in standard errors: Student's t with 5 x logs - 1
    degrees of freedom (2.78 for one log), a small-sample allowance for an effective sample
    size that is itself estimated and often a few samples per log."""
    return float(stats.t.ppf(0.975, max(5 * logs - 1, 1)))


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
    """The standard errors of a fit and what they come from (unit coordinates of the
    Jacobian given).

    Attributes:
        stderr: (n,) reported: ``factor`` x the larger of ``naive`` and ``row`` (inf: not
            determined).
        naive, row: (n,) :func:`naive_stderr`, :func:`row_stderr`.
        samples: sample rows of all logs.
        effective: effective independent samples (:func:`effective_samples`).
        correlation_time: (logs,) each log's :func:`correlation_time` [s].
        factor: sqrt(samples / effective) [-].
    """

    stderr: np.ndarray
    naive: np.ndarray
    row: np.ndarray
    samples: float
    effective: float
    correlation_time: tuple[float, ...]
    factor: float


def fit_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
               periods: np.ndarray) -> FitErrors:
    """The reported standard errors: the larger of the independent-sample and per-reading
    errors, times sqrt(samples / effective samples) of the residuals' correlation time
    (arguments as :func:`row_stderr` and :func:`effective_samples`)."""
    naive = naive_stderr(jac, residual)
    row = row_stderr(jac, residual, rows)
    samples, effective, taus = effective_samples(residual, rows, cables, periods)
    factor = float(np.sqrt(samples / effective)) if effective > 0 else float("inf")
    return FitErrors(factor * np.maximum(naive, row), naive, row, samples, effective,
                     tuple(taus), factor)
