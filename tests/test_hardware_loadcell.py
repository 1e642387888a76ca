"""Load-cell calibration (paper eq. 7): the fit recovers known coefficients with the
statistically expected spread, quantisation sits on the count grid, raw logs convert."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.hardware import (
    PAPER_LOADCELL,
    LoadCell,
    LogError,
    convert_log,
    fit_loadcell,
    load_log,
    read_log,
    read_pairs,
)

A, B = 0.1567, -4.9363  # the paper's eq. (7) [N per count], [N]


def _design() -> np.ndarray:
    """ADC readings of 40 loads spread over the calibrated range (0 to 111 N)."""
    return np.linspace(32.0, 740.0, 40)


def _theory(adc: np.ndarray, sigma: float) -> tuple[float, float]:
    """Standard errors of slope and intercept of an OLS line with noise sigma (closed form)."""
    sxx = ((adc - adc.mean()) ** 2).sum()
    return sigma / np.sqrt(sxx), sigma * np.sqrt(1.0 / adc.size + adc.mean() ** 2 / sxx)


def test_fit_recovers_known_coefficients():
    adc, sigma = _design(), 0.3
    force = A * adc + B + np.random.default_rng(0).normal(0.0, sigma, adc.size)
    fit = fit_loadcell(adc, force)
    se_a, se_b = _theory(adc, sigma)
    # 4 standard errors: a 1-in-15000 chance of a false failure for a correct fit
    assert abs(fit.loadcell.gain - A) < 4 * se_a
    assert abs(fit.loadcell.offset - B) < 4 * se_b
    # the reported errors estimate sigma from 38 degrees of freedom: about 11 % spread
    assert fit.gain_stderr == pytest.approx(se_a, rel=0.35)
    assert fit.offset_stderr == pytest.approx(se_b, rel=0.35)
    assert fit.residual_rms == pytest.approx(sigma, rel=0.35)
    assert fit.loadcell.gain == pytest.approx(0.16, abs=0.005)  # "about 0.16 N per count"


def test_fit_spread_matches_ols_theory():
    adc, sigma = _design(), 0.3
    rng = np.random.default_rng(1)
    gains = [fit_loadcell(adc, A * adc + B + rng.normal(0.0, sigma, adc.size)).loadcell.gain
             for _ in range(400)]
    # 400 trials: the sample standard deviation is within 3.5 % (1 sigma) of the truth
    assert np.std(gains, ddof=1) == pytest.approx(_theory(adc, sigma)[0], rel=0.15)
    assert np.mean(gains) == pytest.approx(A, abs=4 * _theory(adc, sigma)[0] / 20)


def test_quantise_on_count_grid_and_range():
    cell = LoadCell(A, B, max_force=111.21)
    force = np.array([-10.0, 0.0, 10.0, 10.07, 50.0, 200.0])
    reading = cell.quantise(force)
    counts = (reading[:-1] - B) / A
    np.testing.assert_allclose(counts, np.rint(counts), atol=1e-9)  # whole counts
    assert np.abs(reading[1:-1] - force[1:-1]).max() <= A / 2 + 1e-12  # half a count
    assert reading[0] == pytest.approx(B)  # 0 counts: the ADC cannot read below
    assert reading[-1] == pytest.approx(111.21)  # clipped at the calibrated maximum
    assert cell.to_newtons(100) == pytest.approx(0.1567 * 100 - 4.9363)


def test_read_pairs_and_errors(tmp_path):
    good = tmp_path / "pairs.csv"
    good.write_text("# weights\nadc,force_N\n32,0\n94,9.81\n")
    adc, force = read_pairs(good)
    np.testing.assert_array_equal(adc, [32, 94])
    np.testing.assert_array_equal(force, [0.0, 9.81])
    bad = tmp_path / "bad.csv"
    bad.write_text("adc,force_N\n32,0\n94,heavy\n")
    with pytest.raises(LogError, match=r"bad\.csv: line 3, column 'force_N': expected a number"):
        read_pairs(bad)
    header = tmp_path / "header.csv"
    header.write_text("counts,newtons\n1,2\n")
    with pytest.raises(LogError, match=r"header\.csv: line 1: expected the header"):
        read_pairs(header)


def test_raw_log_converts_to_newtons(tmp_path):
    raw = tmp_path / "raw.csv"
    raw.write_text("time_s,adc/c1,tension_N/c2\n0,100,5\n0.2,101,6\n")
    log = read_log(raw)
    newtons = convert_log(log, PAPER_LOADCELL)
    np.testing.assert_allclose(newtons.series["tension/c1"], [A * 100 + B, A * 101 + B])
    np.testing.assert_array_equal(newtons.series["tension/c2"], [5, 6])
    assert "adc/c1" not in newtons.series.channels
    # a calibration in the header wins over eq. (7)
    raw.write_text("# loadcell: 0.2 * ADC + -1\ntime_s,adc/c1\n0,100\n0.2,100\n")
    assert load_log(raw).series["tension/c1"][0] == pytest.approx(19.0)
