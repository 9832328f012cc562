//! Excitation signals of lifted-prbs: PRBS and inverse PRBS (the CLI's
//! `lifted prbs`), the PRBS design of Zhu 2000 §III.D, random binary
//! signals, generalized binary noise and multisines. O(length) each; the
//! generation runs with the GIL released.

use lifted_linalg::budget::Size;
use lifted_prbs::{
    DesignRequest, GbnOptions, InversePrbs, InversePrbsOptions, MSequence, MultisineOptions,
    RandomBinaryOptions,
};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Int, budget, count, int, opt_int, seed as seed_of, small};
use crate::errors::{arg_error, err, work_budget};

/// `periods` periods of `period` samples, refused above the in-memory
/// limit of lifted-prbs.
fn length(period: u128, periods: usize) -> PyResult<usize> {
    if periods == 0 {
        return Err(arg_error("periods", "must be at least 1"));
    }
    let len = period * periods as u128;
    if len > lifted_prbs::MAX_SIGNAL_ENTRIES {
        return Err(err(lifted_prbs::Error::TooLong {
            samples: len,
            max: lifted_prbs::MAX_SIGNAL_ENTRIES,
        }));
    }
    let len = len as usize;
    budget("the signal", Size::f64s(len))?;
    Ok(len)
}

/// Maximum-length PRBS of shift-register order `order` mapped to ±amplitude,
/// each bit held `hold` samples, `periods` periods, the register advanced by
/// `seed mod period` first (same signal as `lifted prbs`). O(length).
#[pyfunction]
#[pyo3(signature = (order, amplitude=1.0, hold=1, periods=1, seed=0))]
pub(crate) fn prbs<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = int)] order: Int,
    amplitude: f64,
    #[pyo3(from_py_with = int)] hold: Int,
    #[pyo3(from_py_with = int)] periods: Int,
    #[pyo3(from_py_with = int)] seed: Int,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (order, hold) = (small(order, "order")?, count(hold, "hold")?);
    let (periods, seed) = (count(periods, "periods")?, seed_of(seed, "seed")?);
    // Validate through the inverse-PRBS options (order, amplitude, hold), as the CLI.
    InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .map_err(err)?;
    let mut seq = MSequence::new(order).map_err(err)?;
    let m = seq.period();
    let len = length(m as u128 * hold as u128, periods)?;
    let w = py.detach(move || {
        seq.advance(seed % m);
        let mut w = Vec::with_capacity(len);
        while w.len() < len {
            let v = if seq.next_bit() == 1 {
                amplitude
            } else {
                -amplitude
            };
            let take = (len - w.len()).min(hold);
            w.extend(std::iter::repeat_n(v, take));
        }
        w
    });
    Ok(PyArray1::from_vec(py, w))
}

/// Inverse PRBS (Zhu 2000 eq. II-4) held `hold` samples: `periods` periods
/// of 2·hold·m samples, started `seed mod period` samples in (as
/// `lifted prbs --inverse`). O(length).
#[pyfunction]
#[pyo3(signature = (order, amplitude=1.0, hold=1, periods=1, seed=0))]
pub(crate) fn inverse_prbs<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = int)] order: Int,
    amplitude: f64,
    #[pyo3(from_py_with = int)] hold: Int,
    #[pyo3(from_py_with = int)] periods: Int,
    #[pyo3(from_py_with = int)] seed: Int,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (order, hold) = (small(order, "order")?, count(hold, "hold")?);
    let (periods, seed) = (count(periods, "periods")?, seed_of(seed, "seed")?);
    let p = InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .map_err(err)?;
    let len = length(p.period() as u128, periods)?;
    let shift = (seed % p.period()) as usize;
    let w: Vec<f64> = py.detach(move || p.iter().skip(shift).take(len).collect());
    Ok(PyArray1::from_vec(py, w))
}

/// PRBS design (lifted_prbs::design, Zhu 2000 §III.D): proposes (order,
/// hold, amplitude) from the plant's time scales and the actuator rate.
/// Keyword defaults are `DesignRequest`'s (Table II). Returns a dict of the
/// `DesignProposal` fields.
#[pyfunction]
#[pyo3(signature = (output_period=0.01, actuator_rate_hz=30.0, actuator_margin=3.0,
    slowest_mode_hz=0.025, amplitude=1.0, min_order=2))]
pub(crate) fn design<'py>(
    py: Python<'py>,
    output_period: f64,
    actuator_rate_hz: f64,
    actuator_margin: f64,
    slowest_mode_hz: f64,
    amplitude: f64,
    #[pyo3(from_py_with = int)] min_order: Int,
) -> PyResult<Bound<'py, PyDict>> {
    let min_order = small(min_order, "min_order")?;
    let p = lifted_prbs::design(&DesignRequest {
        output_period,
        actuator_rate_hz,
        actuator_margin,
        slowest_mode_hz,
        amplitude,
        min_order,
    })
    .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("order", p.order)?;
    out.set_item("m", p.m)?;
    out.set_item("hold", p.hold)?;
    out.set_item("amplitude", p.amplitude)?;
    out.set_item("output_period", p.output_period)?;
    out.set_item("generation_period", p.generation_period)?;
    out.set_item("period_samples", p.period_samples)?;
    out.set_item("record_length_s", p.record_length_s)?;
    out.set_item("fundamental_hz", p.fundamental_hz)?;
    out.set_item("band_high_hz", p.band_high_hz)?;
    out.set_item("hold_null_hz", p.hold_null_hz)?;
    out.set_item("explanation", p.explanation)?;
    Ok(out)
}

/// The length `n` of a generated signal, checked against the memory
/// budget (the signal and one working copy).
fn signal_length(n: Int) -> PyResult<usize> {
    let n = count(n, "n")?;
    budget("the signal (n samples)", Size::f64s(n).times(2))?;
    Ok(n)
}

/// Random binary signal ±amplitude held `hold` samples (lifted_prbs::random_binary).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, hold=1, seed=0))]
pub(crate) fn rbs<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = int)] n: Int,
    amplitude: f64,
    #[pyo3(from_py_with = int)] hold: Int,
    #[pyo3(from_py_with = int)] seed: Int,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n = signal_length(n)?;
    let o = RandomBinaryOptions {
        amplitude,
        hold: count(hold, "hold")?,
        seed: seed_of(seed, "seed")?,
    };
    let v = py
        .detach(move || lifted_prbs::random_binary(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}

/// Generalized binary noise (lifted_prbs::generalized_binary_noise).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, switch_probability=0.5, hold=1, seed=0))]
pub(crate) fn gbn<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = int)] n: Int,
    amplitude: f64,
    switch_probability: f64,
    #[pyo3(from_py_with = int)] hold: Int,
    #[pyo3(from_py_with = int)] seed: Int,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n = signal_length(n)?;
    let o = GbnOptions {
        amplitude,
        switch_probability,
        hold: count(hold, "hold")?,
        seed: seed_of(seed, "seed")?,
    };
    let v = py
        .detach(move || lifted_prbs::generalized_binary_noise(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}

/// Bound on the cosine evaluations of one multisine period (period ×
/// harmonics), about ten seconds of work.
const MULTISINE_WORK: f64 = 1e9;

/// lifted_prbs::multisine tabulates one whole period (period × harmonics
/// cosines) before it copies the record out, whatever the record length:
/// the table is checked against the memory budget and the work bound here,
/// so that a period of 2⁴⁰ is an error and not an abort.
fn check_multisine(period: usize, first: usize, last: Option<Int>) -> PyResult<()> {
    lifted_linalg::budget::MemoryBudget::default()
        .check(
            "the multisine period table",
            lifted_linalg::budget::Size::f64s(period),
        )
        .map_err(err)?;
    let last = match last {
        Some(l) => count(l, "last_harmonic")?,
        None => period.div_ceil(2).saturating_sub(1),
    };
    let harmonics = last.saturating_sub(first).saturating_add(1) as f64;
    let work = harmonics * period as f64;
    if work > MULTISINE_WORK {
        return Err(work_budget(
            "multisine (period x harmonics cosines)",
            work,
            MULTISINE_WORK,
        ));
    }
    Ok(())
}

/// Periodic multisine of RMS `amplitude` (lifted_prbs::multisine).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, period=1024, first_harmonic=1, last_harmonic=None))]
pub(crate) fn multisine<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = int)] n: Int,
    amplitude: f64,
    #[pyo3(from_py_with = int)] period: Int,
    #[pyo3(from_py_with = int)] first_harmonic: Int,
    #[pyo3(from_py_with = opt_int)] last_harmonic: Option<Int>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n = signal_length(n)?;
    let period = count(period, "period")?;
    check_multisine(
        period,
        count(first_harmonic, "first_harmonic")?,
        last_harmonic,
    )?;
    let o = MultisineOptions {
        amplitude,
        period,
        first_harmonic: count(first_harmonic, "first_harmonic")?,
        last_harmonic: crate::convert::opt_count(last_harmonic, "last_harmonic")?,
    };
    let v = py
        .detach(move || lifted_prbs::multisine(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}
