"""Standard errors of a least-squares fit whose residuals are correlated and hold model error.

A simulated run's residuals stay correlated over many samples: a model error lasts as long
as the motion that shows it, hits every cable at once, and repeats with the gait. The
textbook s^2 (J^T J)^-1 counts every sample as independent and is then far too small, and on
a log of another model than the one fitted (a real robot) the fits on other windows of the
same log disagree by several of its standard errors. :func:`fit_stderr` counts the samples
once, by the long-run variance of a series (its lag-0 variance times 1 + 2 sum |rho_l|):

- of the residuals: the larger of :func:`naive_stderr`, s^2 (J^T J)^-1, and
  :func:`row_stderr` (all cables of one reading together), times samples / effective samples,
  where :func:`correlation_time` is the residuals' integrated autocorrelation time in seconds,
  tau = dt (1/2 + sum |rho_l|), and :func:`effective_samples` is n_eff = T / (2 tau) per log
  of duration T = samples x dt, summed over the logs;
- of each parameter's own score, :func:`score_stderr`: the influence (J^T J)^-1 J_t^T r_t of
  each sample time t (all cables of one reading together: a model error moves them
  together), whose lag-0 sum is the sandwich clustered by sample time (:func:`row_stderr`).
  A model error shows where a parameter's reading changes fast (a delay's where the tension
  does), so its score holds it more than the residuals do, and it is the score's own
  correlation, not the residuals', that sets how few independent samples it has;

and the reported error is the larger of the two. Magnitudes |rho_l|, since a periodic model
error correlates negatively at half the gait's period and positively at the period, and which
of them a parameter's score follows is not known.

The sums run over one window per log, fixed by the motion and not by the residuals: the
longest of Sokal's self-consistent windows (the first lag of at least 5 tau, at most half the
samples) of the Jacobian's columns (:func:`motion_window`), which hold no sensor noise and
change little with the fit point. A window taken from the residuals' own correlation would
shrink when white noise is added (noise adds to the lag-0 variance only, so it shrinks every
rho_l) and drop the model error's correlation with it. Over a fixed window, white noise adds
its variance at lag 0 and only chance terms at the other lags, so on one fit noise widens
every interval (tests: sensor noise on one fit, at a fixed fit point on a simulated log). A
noise-free series (:func:`correlation_time` without a Jacobian) uses Sokal's window of its own
|rho_l|.

The same motion logged at another rate has the same correlation time in seconds, so the same
n_eff and about the same interval. A model error that the fitted model cannot represent
correlates over the whole window (tau of a fraction of the gait's period and more) and leaves
only a few effective samples, so the interval also holds a bias that every sample shares,
which the scatter of the samples does not show.
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


def _sokal_window(terms: np.ndarray) -> int:
    """Sokal's window: the first lag M with M >= SOKAL_WINDOW (1/2 + sum of ``terms`` to M)."""
    total = 0.0
    for lag, value in enumerate(terms, start=1):
        total += float(value)
        if lag >= SOKAL_WINDOW * (0.5 + total):
            return lag
    return len(terms)


def _autocorrelation(series: np.ndarray) -> tuple[np.ndarray, int]:
    """rho_l for lags 1..len // 2 of a (samples,) or (samples, columns) series pooled over its
    columns (NaN: no sample), and the number of its samples."""
    grid = series if series.ndim == 2 else series[:, None]
    variance = float(np.nansum(grid**2))
    cells = int(np.isfinite(grid).sum())
    if variance <= 0 or len(grid) < 4:
        return np.zeros(0), cells
    rho = np.array([float(np.nansum(grid[lag:] * grid[:-lag])) / variance
                    for lag in range(1, len(grid) // 2 + 1)])
    return rho, cells


def long_run_ratio(series: np.ndarray, window: int | None = None) -> float:
    """The long-run variance of a centred series over its lag-0 variance, 1 + 2 sum |rho_l|
    (2 tau / dt), over lags 1..``window`` (None: Sokal's window of its own |rho_l|).

    Args:
        series: (samples,) or (samples, columns) centred series (NaN: no sample); the
            columns' lag products are pooled.
        window: the window of the motion that shapes the series [lags]
            (:func:`motion_window`).
    """
    rho, _ = _autocorrelation(series)
    if rho.size == 0:
        return 1.0
    if window is None:
        window = _sokal_window(np.abs(rho))
    return 1.0 + 2.0 * float(np.abs(rho[:window]).sum())


def motion_window(jac: np.ndarray, rows: np.ndarray, cables: np.ndarray) -> int:
    """The window [lags] of the motion that shapes the residuals of one log: the longest
    Sokal window of the Jacobian's columns (each simulated reading's sensitivity to a
    parameter, per cable less its mean), which hold no sensor noise. A column that is the same
    at every sample of a cable (an offset's) has no motion and no say.

    Args:
        jac: (m, n) Jacobian rows of one log.
        rows, cables: as :func:`correlation_time`.
    """
    windows = [1]
    for column in jac.T:
        grid = _grid(column, rows, cables)
        if np.nansum(grid**2) <= 1e-12 * float(column @ column):
            continue  # constant per cable: rounding noise only
        rho, _ = _autocorrelation(grid)
        if rho.size:
            windows.append(_sokal_window(np.abs(rho)))
    return max(windows)


def correlation_time(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
                     period: float, window: int | None = None) -> float:
    """The residuals' integrated autocorrelation time [s] in one log sampled every ``period``.

    Per cable the residuals (less their mean) form a series over the sample rows; for each
    lag the products of samples that far apart are pooled over cables and divided by the
    pooled variance (rho_l). tau = period (1/2 + sum |rho_l|) = period x
    :func:`long_run_ratio` / 2. Independent residuals give tau of about half a period.

    Args:
        residual: (m,) residuals of one log.
        rows: (m,) their sample-row labels (:func:`row_stderr`).
        cables: (m,) index of each residual's cable.
        period: time between the log's sample rows [s].
        window: :func:`motion_window` [lags] (None: Sokal's window of the residuals' own
            |rho_l|).
    """
    return 0.5 * period * long_run_ratio(_grid(residual, rows, cables), window)


def effective_samples(residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
                      periods: np.ndarray, jac: np.ndarray | None = None
                      ) -> tuple[float, float, list[float]]:
    """Sample rows, effective independent samples (n_eff = T / (2 tau) per log of duration
    T = rows x period, summed) and each log's correlation time [s].

    Args:
        residual, rows, cables: as :func:`correlation_time`, all logs.
        periods: (logs,) each log's time between sample rows [s].
        jac: (m, n) the Jacobian, for each log's :func:`motion_window` (None: none).
    """
    samples, effective, taus = 0.0, 0.0, []
    for log in np.unique(rows // LOG_STRIDE):
        own = rows // LOG_STRIDE == log
        count = np.unique(rows[own]).size
        window = None if jac is None else motion_window(jac[own], rows[own], cables[own])
        tau = correlation_time(residual[own], rows[own], cables[own], float(periods[log]),
                               window)
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


def score_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray,
                 cables: np.ndarray) -> np.ndarray:
    """Per parameter, the long-run standard error of its score: the influence
    (J^T J)^-1 J_t^T r_t of each sample row t (all its cables), its lag-0 sum times
    :func:`long_run_ratio` of that parameter's influence series (over the log's
    :func:`motion_window`), per log, summed over the logs (the small-sample
    factor T / (T - n) as :func:`row_stderr`).

    Args:
        jac, residual, rows: as :func:`row_stderr`.
        cables: (m,) index of each residual's cable.

    Returns:
        (n,) standard errors (inf: not determined).
    """
    labels, scores = _row_scores(jac, residual, rows)
    n = jac.shape[1]
    bread = _bread(jac)
    if bread is None or len(scores) <= n:
        return np.full(n, np.inf)
    influence = scores @ bread
    variance = np.zeros(n)
    for log in np.unique(labels // LOG_STRIDE):
        own = influence[labels // LOG_STRIDE == log]
        cells = rows // LOG_STRIDE == log
        window = motion_window(jac[cells], rows[cells], cables[cells])
        for k in range(n):
            series = own[:, k] - own[:, k].mean()
            variance[k] += float(own[:, k] @ own[:, k]) * long_run_ratio(series, window)
    return np.sqrt(variance * len(scores) / (len(scores) - n))


@dataclasses.dataclass(frozen=True)
class FitErrors:
    """The standard errors of a fit and what they come from (unit coordinates of the
    Jacobian given).

    Attributes:
        stderr: (n,) reported: the larger of ``factor`` x the larger of ``naive`` and ``row``,
            and ``score`` (inf: not determined).
        naive, row, score: (n,) :func:`naive_stderr`, :func:`row_stderr` (lag 0 of
            ``score``), :func:`score_stderr`.
        samples: sample rows of all logs.
        effective: effective independent samples (:func:`effective_samples`).
        correlation_time: (logs,) each log's :func:`correlation_time` [s].
        factor: sqrt(samples / effective) [-].
    """

    stderr: np.ndarray
    naive: np.ndarray
    row: np.ndarray
    score: np.ndarray
    samples: float
    effective: float
    correlation_time: tuple[float, ...]
    factor: float


def fit_stderr(jac: np.ndarray, residual: np.ndarray, rows: np.ndarray, cables: np.ndarray,
               periods: np.ndarray) -> FitErrors:
    """The reported standard errors: the larger of the independent-sample and per-reading
    errors times sqrt(samples / effective samples) of the residuals' correlation time, and
    each parameter's long-run score error (arguments as :func:`row_stderr` and
    :func:`effective_samples`)."""
    naive = naive_stderr(jac, residual)
    row = row_stderr(jac, residual, rows)
    score = score_stderr(jac, residual, rows, cables)
    samples, effective, taus = effective_samples(residual, rows, cables, periods, jac)
    factor = float(np.sqrt(samples / effective)) if effective > 0 else float("inf")
    return FitErrors(np.maximum(factor * np.maximum(naive, row), score), naive, row, score,
                     samples, effective, tuple(taus), factor)
