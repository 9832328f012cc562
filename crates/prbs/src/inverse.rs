//! The inverse PRBS of Zhu 2000 eq. (II-4) / Ren & Zhu 2009 eq. (5), optionally held
//! `n_r` fast samples (eq. II-7), and its closed-form autocorrelations (II-6, II-10).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_amplitude, check_factor};
use crate::mseq::{MSequence, MSequenceSpec, WordGenerator};

/// Bits at odd positions of a word: the alternating sign `s(k)` of eq. (II-4).
const ODD_BITS: u64 = 0xAAAA_AAAA_AAAA_AAAA;

/// Options of an inverse PRBS. Validated by [`InversePrbs::new`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct InversePrbsOptions {
    /// Order `n` of the m-sequence, period `m = 2ⁿ − 1` (eq. II-1). Default 8
    /// (Zhu 2000 Table II).
    pub order: u32,
    /// Magnitude `a > 0` (eqs. II-3, II-4). Default 1.0.
    pub amplitude: f64,
    /// Hold factor `n_r = T_p / T ≥ 1` (eq. II-7): each generated value is repeated
    /// `n_r` fast samples. Default 1 (single rate).
    pub hold: usize,
    /// Feedback taps `S_n`; `None` (default) uses Table I (orders 2..=11) or the
    /// built-in table. User taps must give a maximal sequence.
    pub taps: Option<Vec<u32>>,
}

impl Default for InversePrbsOptions {
    fn default() -> Self {
        Self {
            order: 8,
            amplitude: 1.0,
            hold: 1,
            taps: None,
        }
    }
}

/// A validated inverse PRBS `u(k) = (−1)^{k+1} · a · (2b(k) − 1)` (spec A1.2, erratum
/// RZ-2), held `n_r` samples: `w(j) = u(⌊j / n_r⌋)`.
///
/// Period `2m` at the generation rate (`u(k+m) = −u(k)`, zero mean, eq. II-5) and
/// `2 n_r m` at the fast rate (eq. II-8).
///
/// Serialised as its [`InversePrbsOptions`] and validated again when loaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "InversePrbsOptions", into = "InversePrbsOptions")]
pub struct InversePrbs {
    register: MSequence,
    amplitude: f64,
    hold: usize,
}

impl InversePrbs {
    /// Validates `options` and builds the generator.
    ///
    /// # Errors
    /// [`Error::OrderOutOfRange`], [`Error::InvalidTaps`], [`Error::NotMaximal`],
    /// [`Error::InvalidAmplitude`], [`Error::ZeroFactor`] (hold `n_r = 0`).
    pub fn new(options: &InversePrbsOptions) -> Result<Self> {
        check_amplitude(options.amplitude)?;
        check_factor("hold n_r", options.hold)?;
        let register = MSequenceSpec {
            order: options.order,
            taps: options.taps.clone(),
        }
        .build()?;
        if options.taps.is_some() && !register.is_maximal() {
            return Err(Error::NotMaximal {
                order: options.order,
                taps: register.taps().to_vec(),
            });
        }
        Ok(Self {
            register,
            amplitude: options.amplitude,
            hold: options.hold,
        })
    }

    /// Order `n`.
    pub fn order(&self) -> u32 {
        self.register.order()
    }

    /// Feedback taps in use.
    pub fn taps(&self) -> &[u32] {
        self.register.taps()
    }

    /// Magnitude `a`.
    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }

    /// Hold factor `n_r`.
    pub fn hold(&self) -> usize {
        self.hold
    }

    /// m-sequence period `m = 2ⁿ − 1`.
    pub fn m(&self) -> u64 {
        self.register.period()
    }

    /// Period at the generation rate, `2m`.
    pub fn slow_period(&self) -> u64 {
        2 * self.m()
    }

    /// Period at the fast rate, `2 n_r m` (eq. II-8).
    pub fn period(&self) -> u64 {
        2 * self.hold as u64 * self.m()
    }

    /// The options that rebuild this generator.
    pub fn options(&self) -> InversePrbsOptions {
        InversePrbsOptions {
            order: self.order(),
            amplitude: self.amplitude,
            hold: self.hold,
            taps: Some(self.taps().to_vec()),
        }
    }

    /// Allocation-free iterator over the fast-rate samples `w(0), w(1), …` (infinite).
    /// O(1) per sample.
    pub fn iter(&self) -> InversePrbsIter {
        let mut register = self.register.clone();
        let first = sign_value(register.next_bit(), 0, self.amplitude);
        InversePrbsIter {
            register,
            amplitude: self.amplitude,
            hold: self.hold,
            left: self.hold,
            slow_index: 0,
            current: first,
        }
    }

    /// The slow-rate signs `u(k)/a ∈ {−1, +1}`, `k < len`, as integers (exact arithmetic).
    /// O(len).
    pub fn slow_signs(&self, len: usize) -> Vec<i8> {
        let mut reg = self.register.clone();
        (0..len)
            .map(|k| {
                let b = reg.next_bit();
                if b as usize == (k & 1) { 1 } else { -1 }
            })
            .collect()
    }

    /// Bulk generator: the first `len` fast-rate samples. Uses the word-parallel
    /// register (64 generation-rate bits per step); O(len), one allocation.
    pub fn generate(&self, len: usize) -> Vec<f64> {
        let mut out = Vec::with_capacity(len);
        let mut words: WordGenerator = self.register.clone().into_words();
        let table = [self.amplitude, -self.amplitude];
        let hold = self.hold;
        'outer: loop {
            // Bit j set <=> u(64t + j) = −a.
            let c = words.next_word() ^ ODD_BITS;
            if hold == 1 {
                let take = (len - out.len()).min(64);
                out.extend((0..take).map(|j| table[((c >> j) & 1) as usize]));
                if out.len() == len {
                    break;
                }
            } else {
                for j in 0..64 {
                    let v = table[((c >> j) & 1) as usize];
                    let take = (len - out.len()).min(hold);
                    out.extend(std::iter::repeat_n(v, take));
                    if out.len() == len {
                        break 'outer;
                    }
                }
            }
        }
        out
    }

    /// One fast-rate period (`2 n_r m` samples).
    ///
    /// Allocates the whole period: for large orders (order 32 is 8.6e9 · n_r samples)
    /// use [`InversePrbs::iter`] or [`InversePrbs::generate`] in blocks instead.
    pub fn one_period(&self) -> Vec<f64> {
        self.generate(self.period() as usize)
    }

    /// Closed-form slow-rate autocorrelation, eq. (II-6):
    /// `R_u(τ) = (1/2m) Σ_{k<2m} u(k+τ) u(k)`.
    pub fn slow_autocorrelation(&self, tau: i64) -> f64 {
        slow_autocorrelation_m(self.m(), self.amplitude, tau)
    }

    /// Closed-form fast-rate autocorrelation of the held sequence, corrected eq. (II-10)
    /// (spec A1.3, errata Z-2/Z-3): `R_w(τ) = (1/2m) Σ_{k<2n_r m} w(k+τ) w(k)`, circular.
    /// Equals [`InversePrbs::slow_autocorrelation`] for `n_r = 1`. O(1).
    pub fn autocorrelation(&self, tau: i64) -> f64 {
        held_autocorrelation_m(self.m(), self.hold as u64, self.amplitude, tau)
    }
}

impl TryFrom<InversePrbsOptions> for InversePrbs {
    type Error = Error;

    fn try_from(options: InversePrbsOptions) -> Result<Self> {
        Self::new(&options)
    }
}

impl From<InversePrbs> for InversePrbsOptions {
    fn from(prbs: InversePrbs) -> Self {
        prbs.options()
    }
}

/// `(−1)^{k+1}·a·(2b−1)`: `+a` iff `b == k mod 2`.
#[inline]
fn sign_value(bit: u8, k: u64, a: f64) -> f64 {
    if bit as u64 == (k & 1) { a } else { -a }
}

/// Fast-rate samples of a held inverse PRBS; see [`InversePrbs::iter`].
#[derive(Debug, Clone)]
pub struct InversePrbsIter {
    register: MSequence,
    amplitude: f64,
    hold: usize,
    left: usize,
    slow_index: u64,
    current: f64,
}

impl Iterator for InversePrbsIter {
    type Item = f64;

    #[inline]
    fn next(&mut self) -> Option<f64> {
        if self.left == 0 {
            self.slow_index += 1;
            self.current = sign_value(self.register.next_bit(), self.slow_index, self.amplitude);
            self.left = self.hold;
        }
        self.left -= 1;
        Some(self.current)
    }
}

fn slow_autocorrelation_m(m: u64, a: f64, tau: i64) -> f64 {
    let t = tau.rem_euclid(2 * m as i64) as u64;
    let a2 = a * a;
    if t == 0 {
        a2
    } else if t == m {
        -a2
    } else if t.is_multiple_of(2) {
        -a2 / m as f64
    } else {
        a2 / m as f64
    }
}

fn held_autocorrelation_m(m: u64, nr: u64, a: f64, tau: i64) -> f64 {
    let half = (nr * m) as i64;
    let t = tau.rem_euclid(2 * half);
    if t >= half {
        return -held_autocorrelation_m(m, nr, a, t - half);
    }
    let t = t as u64;
    let (q, tb) = (t / nr, (t % nr) as f64);
    let (nrf, mf, a2) = (nr as f64, m as f64, a * a);
    if q == 0 {
        ((nrf - tb) + tb / mf) * a2
    } else if q == m - 1 {
        (-tb - (nrf - tb) / mf) * a2
    } else if q.is_multiple_of(2) {
        -(nrf - 2.0 * tb) / mf * a2
    } else {
        (nrf - 2.0 * tb) / mf * a2
    }
}

/// Closed-form autocorrelation of the inverse PRBS of order `n` and magnitude `a`,
/// eq. (II-6), at lag `τ` (any sign; circular with period `2m`).
///
/// # Errors
/// [`Error::OrderOutOfRange`], [`Error::InvalidAmplitude`].
pub fn inverse_prbs_autocorrelation(order: u32, amplitude: f64, tau: i64) -> Result<f64> {
    let m = crate::mseq::period(order)?;
    check_amplitude(amplitude)?;
    Ok(slow_autocorrelation_m(m, amplitude, tau))
}

/// Closed-form autocorrelation of the inverse PRBS of order `n`, magnitude `a`, held
/// `n_r` samples: corrected eq. (II-10) (spec A1.3; errata Z-2, Z-3), normalised by
/// `1/(2m)`, circular with period `2 n_r m`. With `τ = q n_r + τ̄` (`0 ≤ τ < n_r m`):
///
/// * `q = 0`: `(n_r − τ̄)a² + τ̄a²/m`
/// * `q = m−1`: `−τ̄a² − (n_r − τ̄)a²/m`
/// * otherwise `∓(n_r − 2τ̄)a²/m` for `q` even / odd,
/// * and `R(τ + n_r m) = −R(τ)`.
///
/// O(1). Used as the test oracle and for the q-Markov weighting `W(τ)`.
///
/// # Errors
/// [`Error::OrderOutOfRange`], [`Error::InvalidAmplitude`], [`Error::ZeroFactor`].
pub fn held_autocorrelation(order: u32, hold: usize, amplitude: f64, tau: i64) -> Result<f64> {
    let m = crate::mseq::period(order)?;
    check_amplitude(amplitude)?;
    check_factor("hold n_r", hold)?;
    Ok(held_autocorrelation_m(m, hold as u64, amplitude, tau))
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn golden_prefix_order5() {
        let p = InversePrbs::new(&InversePrbsOptions {
            order: 5,
            ..Default::default()
        })
        .unwrap();
        let s = p.slow_signs(10);
        assert_eq!(s, [-1, -1, 1, 1, 1, 1, -1, -1, 1, 1]);
    }

    #[test]
    fn iterator_equals_bulk() {
        for hold in [1, 2, 3, 7, 64, 65] {
            let p = InversePrbs::new(&InversePrbsOptions {
                order: 6,
                amplitude: 1.5,
                hold,
                taps: None,
            })
            .unwrap();
            let len = 3 * p.period() as usize + 11;
            let a: Vec<f64> = p.iter().take(len).collect();
            assert_eq!(a, p.generate(len));
        }
    }
}
