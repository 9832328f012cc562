//! Lifting of multirate signals and data sets (thesis §3.1, §4.2, §5.2, §7.5).
//!
//! A multirate record lives on the fast grid t = kT. Input channel c is held
//! for m_c base periods, output channel o is sampled every J_o base periods
//! at phase offset_o. Over one frame of J = lcm(m_c, J_o) base periods the
//! record has J/m_c distinct values of input c (its *slots*, at frame times
//! s·m_c) and J/J_o samples of output o (at frame times offset_o + r·J_o).
//! [`MultirateLifting`] stacks them into one lifted sample per frame:
//! u̲(k) of dimension Σ J/m_c and y̲(k) of dimension Σ J/J_o. The lifted
//! system u̲ → y̲ is LTI with period JT (eq. 4.1, 5.1).
//!
//! The column order is recorded in the lifting ([`Ordering`], spec pitfall
//! 12): [`Ordering::ChannelMajor`] (channel blocks, time inside: Ch. 4–5,
//! for one channel exactly L_n of eq. 3.1) or [`Ordering::TimeMajor`]
//! (time blocks, channels inside: §7.5). Every routine of this crate that
//! takes lifted data asks the lifting for the meaning of a column
//! ([`MultirateLifting::input_slots`], [`MultirateLifting::output_slots`]),
//! so both orders work everywhere.
//!
//! The signal-level operators L_n and L_n⁻¹ are [`lift`] and [`unlift`]
//! (re-exported from the data layer of `lifted-lti`): norm preserving and
//! exactly inverse to each other.

use lifted_linalg::budget::{MemoryBudget, Size};
use lifted_lti::Dataset;
use lifted_lti::{InputChannel, OutputChannel};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_finite, checked_lcm, gcd};

pub use lifted_lti::data::{lift_signal as lift, unlift_signal as unlift};

/// Column order of lifted vectors (spec pitfall 12, erratum L-13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Ordering {
    /// Channel blocks, time-ordered inside: [u₀(0), u₀(m₀), …, u₁(0), …]
    /// (thesis Ch. 4–5). Default.
    #[default]
    ChannelMajor,
    /// Time blocks, channel-ordered inside: [u₀(0), u₁(0), u₀(T), u₁(T), …]
    /// (thesis §7.5). Within a time instant, channels are in index order.
    TimeMajor,
}

/// One lifted coordinate: a channel and its instant within the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Slot {
    /// Channel index (before lifting).
    pub channel: usize,
    /// Instant within the frame, in base periods (0 ≤ time < J). For an
    /// input it is the start of the hold block.
    pub time: usize,
    /// Index of the slot among its channel's slots (s or r).
    pub index: usize,
}

/// The SISO rates of thesis §4.2: hold mT and sampling nT, m and n co-prime.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SisoRates {
    /// Hold m (base periods).
    pub m: usize,
    /// Sampling period n (base periods).
    pub n: usize,
}

impl SisoRates {
    /// Validated rates. Errors: [`Error::InvalidRates`] for zero,
    /// [`Error::NotCoprime`] when gcd(m, n) > 1 (use [`Self::normalized`]).
    pub fn new(m: usize, n: usize) -> Result<Self> {
        if m == 0 || n == 0 {
            return Err(Error::InvalidRates {
                what: "hold m / sampling n",
                reason: format!("must be at least 1, got m = {m}, n = {n}"),
            });
        }
        let g = gcd(m, n);
        if g != 1 {
            return Err(Error::NotCoprime { m, n, gcd: g });
        }
        Ok(SisoRates { m, n })
    }

    /// Absorbs the common factor g = gcd(m, n) into the base period
    /// (thesis §4.2, "without loss of generality"): returns the co-prime
    /// rates (m/g, n/g) and g; the new base period is gT.
    pub fn normalized(m: usize, n: usize) -> Result<(Self, usize)> {
        if m == 0 || n == 0 {
            return Err(Error::InvalidRates {
                what: "hold m / sampling n",
                reason: format!("must be at least 1, got m = {m}, n = {n}"),
            });
        }
        let g = gcd(m, n);
        Ok((SisoRates { m: m / g, n: n / g }, g))
    }

    /// Lifting period mn.
    pub fn period(&self) -> usize {
        self.m * self.n
    }
}

/// The lifting of a multirate sampling pattern (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MultirateLifting {
    period: usize,
    holds: Vec<usize>,
    out_periods: Vec<usize>,
    out_offsets: Vec<usize>,
    ordering: Ordering,
    inputs: Vec<Slot>,
    outputs: Vec<Slot>,
}

/// The lifted channel counts n̲_u = Σ J/m_c and n̲_y = Σ J/J_o checked
/// against the memory budget (the slots, and the n̲_y × n̲_u causal mask and
/// lifted D̄ every route forms) before they are built:
/// `lifted_linalg::Error::TooLarge` (wrapped) for a frame J that the
/// holds and periods make too long.
fn check_lifted_size(holds: &[usize], out_periods: &[usize], period: usize) -> Result<()> {
    let sum = |v: &[usize]| {
        v.iter()
            .try_fold(0usize, |acc, &h| acc.checked_add(period / h))
    };
    let need = match (sum(holds), sum(out_periods)) {
        (Some(nu), Some(ny)) => {
            Size::matrices(2, ny, nu).plus(Size::f64s(nu.saturating_add(ny)).times(4))
        }
        _ => Size::OVERFLOW,
    };
    Ok(MemoryBudget::default().check(
        "the lifted channels of the frame (holds and output periods)",
        need,
    )?)
}

/// [`Error::DimensionMismatch`] unless the signal `m` has `expected` columns.
fn check_columns(what: &'static str, m: &DMatrix<f64>, expected: usize) -> Result<()> {
    if m.ncols() != expected {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{expected} columns"),
            got: format!("{}", m.ncols()),
        });
    }
    Ok(())
}

fn order_slots(mut slots: Vec<Slot>, ordering: Ordering) -> Vec<Slot> {
    match ordering {
        Ordering::ChannelMajor => slots.sort_by_key(|s| (s.channel, s.time)),
        Ordering::TimeMajor => slots.sort_by_key(|s| (s.time, s.channel)),
    }
    slots
}

impl MultirateLifting {
    /// A lifting for inputs held `holds[c]` base periods and outputs sampled
    /// every `out_periods[o]` base periods at phase `out_offsets[o]`; the
    /// frame is J = lcm of all holds and periods. O(J(n_u + n_y)).
    ///
    /// Errors: [`Error::InvalidRates`] for an empty channel list, a zero
    /// hold/period, an offset ≥ its period or lengths that differ.
    pub fn new(
        holds: &[usize],
        out_periods: &[usize],
        out_offsets: &[usize],
        ordering: Ordering,
    ) -> Result<Self> {
        if holds.is_empty() || out_periods.is_empty() {
            return Err(Error::InvalidRates {
                what: "channels",
                reason: "at least one input and one output are needed".into(),
            });
        }
        if out_offsets.len() != out_periods.len() {
            return Err(Error::InvalidRates {
                what: "output offsets",
                reason: format!(
                    "{} offsets for {} outputs",
                    out_offsets.len(),
                    out_periods.len()
                ),
            });
        }
        if let Some(c) = holds.iter().position(|&h| h == 0) {
            return Err(Error::InvalidRates {
                what: "hold",
                reason: format!("input {c} has hold 0"),
            });
        }
        if let Some(o) = out_periods.iter().position(|&p| p == 0) {
            return Err(Error::InvalidRates {
                what: "output period",
                reason: format!("output {o} has period 0"),
            });
        }
        for (o, (&off, &p)) in out_offsets.iter().zip(out_periods).enumerate() {
            if off >= p {
                return Err(Error::InvalidRates {
                    what: "output offset",
                    reason: format!("output {o}: offset {off} not below its period {p}"),
                });
            }
        }
        let period = holds
            .iter()
            .chain(out_periods.iter())
            .try_fold(1usize, |a, &b| checked_lcm(a, b))
            .ok_or_else(|| Error::InvalidRates {
                what: "lifting period",
                reason: "the least common multiple of the holds and output periods overflows"
                    .into(),
            })?;
        check_lifted_size(holds, out_periods, period)?;
        Ok(Self::build(
            holds,
            out_periods,
            out_offsets,
            ordering,
            period,
        ))
    }

    /// SISO hold mT, sampling nT (thesis §4.2, eq. 4.1): frame mn, n lifted
    /// inputs u_j at times jm, m lifted outputs y_i at times in.
    pub fn siso(rates: SisoRates) -> Result<Self> {
        Self::new(&[rates.m], &[rates.n], &[0], Ordering::ChannelMajor)
    }

    /// MIMO with all holds T and output o sampled every `out_periods[o]`·T
    /// (thesis §5.2, Prop. 4: frame J = lcm J_o; §7.5 with
    /// [`Ordering::TimeMajor`]).
    pub fn mimo(n_inputs: usize, out_periods: &[usize], ordering: Ordering) -> Result<Self> {
        let offsets = vec![0; out_periods.len()];
        Self::new(&vec![1; n_inputs], out_periods, &offsets, ordering)
    }

    /// Single-rate lifting by `factor` (eq. 4.6; the lifted noise model
    /// N̲ = L_m N L_m⁻¹ of §4.2 uses it with factor m on the slow grid).
    pub fn uniform(
        factor: usize,
        n_inputs: usize,
        n_outputs: usize,
        ordering: Ordering,
    ) -> Result<Self> {
        if factor == 0 {
            return Err(Error::InvalidRates {
                what: "lifting factor",
                reason: "must be at least 1".into(),
            });
        }
        Self::new_with_period(
            &vec![1; n_inputs],
            &vec![1; n_outputs],
            &vec![0; n_outputs],
            ordering,
            factor,
        )
    }

    /// Slow hold nT with fast sampling T (thesis §3.1, second case, Fig. 3.4).
    pub fn slow_hold(n: usize, n_inputs: usize, n_outputs: usize) -> Result<Self> {
        Self::new(
            &vec![n; n_inputs],
            &vec![1; n_outputs],
            &vec![0; n_outputs],
            Ordering::ChannelMajor,
        )
    }

    /// Like [`Self::new`] but with the frame J given explicitly (a multiple
    /// of every hold and period).
    pub fn new_with_period(
        holds: &[usize],
        out_periods: &[usize],
        out_offsets: &[usize],
        ordering: Ordering,
        period: usize,
    ) -> Result<Self> {
        let base = Self::new(holds, out_periods, out_offsets, ordering)?;
        if period == 0 || !period.is_multiple_of(base.period) {
            return Err(Error::InvalidRates {
                what: "lifting period",
                reason: format!("{period} is not a positive multiple of {}", base.period),
            });
        }
        if period == base.period {
            return Ok(base);
        }
        check_lifted_size(holds, out_periods, period)?;
        Ok(Self::build(
            holds,
            out_periods,
            out_offsets,
            ordering,
            period,
        ))
    }

    /// The slots of a validated pattern for frame `period`.
    fn build(
        holds: &[usize],
        out_periods: &[usize],
        out_offsets: &[usize],
        ordering: Ordering,
        period: usize,
    ) -> Self {
        let mut inputs = Vec::new();
        for (c, &h) in holds.iter().enumerate() {
            for s in 0..period / h {
                inputs.push(Slot {
                    channel: c,
                    time: s * h,
                    index: s,
                });
            }
        }
        let mut outputs = Vec::new();
        for (o, (&p, &off)) in out_periods.iter().zip(out_offsets).enumerate() {
            for r in 0..period / p {
                outputs.push(Slot {
                    channel: o,
                    time: off + r * p,
                    index: r,
                });
            }
        }
        MultirateLifting {
            period,
            holds: holds.to_vec(),
            out_periods: out_periods.to_vec(),
            out_offsets: out_offsets.to_vec(),
            ordering,
            inputs: order_slots(inputs, ordering),
            outputs: order_slots(outputs, ordering),
        }
    }

    /// The lifting of a [`Dataset`]'s sampling pattern. Input hold phases
    /// must be 0 ([`Error::Unsupported`] otherwise: slice the record so the
    /// hold blocks start at k = 0).
    pub fn from_dataset(data: &Dataset, ordering: Ordering) -> Result<Self> {
        if let Some(c) = data.inputs().iter().position(|ch| ch.offset != 0) {
            return Err(Error::Unsupported {
                what: "lifting",
                reason: format!("input {c} has a non-zero hold phase"),
            });
        }
        let holds: Vec<usize> = data.inputs().iter().map(|c| c.hold).collect();
        let periods: Vec<usize> = data.outputs().iter().map(|c| c.period).collect();
        let offsets: Vec<usize> = data.outputs().iter().map(|c| c.offset).collect();
        Self::new(&holds, &periods, &offsets, ordering)
    }

    /// Frame length J in base periods (the lifted sample period is JT).
    pub fn period(&self) -> usize {
        self.period
    }

    /// Input holds m_c.
    pub fn holds(&self) -> &[usize] {
        &self.holds
    }

    /// Output periods J_o.
    pub fn output_periods(&self) -> &[usize] {
        &self.out_periods
    }

    /// Output phases.
    pub fn output_offsets(&self) -> &[usize] {
        &self.out_offsets
    }

    /// The recorded column order.
    pub fn ordering(&self) -> Ordering {
        self.ordering
    }

    /// Number of input channels.
    pub fn n_inputs(&self) -> usize {
        self.holds.len()
    }

    /// Number of output channels.
    pub fn n_outputs(&self) -> usize {
        self.out_periods.len()
    }

    /// Meaning of each lifted input column, in column order.
    pub fn input_slots(&self) -> &[Slot] {
        &self.inputs
    }

    /// Meaning of each lifted output column, in column order.
    pub fn output_slots(&self) -> &[Slot] {
        &self.outputs
    }

    /// Lifted input dimension Σ J/m_c.
    pub fn lifted_inputs(&self) -> usize {
        self.inputs.len()
    }

    /// Lifted output dimension Σ J/J_o.
    pub fn lifted_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// Column of input `channel`, slot `index` (None if out of range).
    pub fn input_column(&self, channel: usize, index: usize) -> Option<usize> {
        self.inputs
            .iter()
            .position(|s| s.channel == channel && s.index == index)
    }

    /// Column of output `channel`, sample `index` (None if out of range).
    pub fn output_column(&self, channel: usize, index: usize) -> Option<usize> {
        self.outputs
            .iter()
            .position(|s| s.channel == channel && s.index == index)
    }

    /// The causality mask of the lifted D̄ (thesis eq. 4.17, spec A3.5):
    /// entry (output slot at τ, input slot starting at t) may be non-zero
    /// iff t < τ when the fast model is strictly proper (residual delay in
    /// (0, 1], or D = 0), iff t ≤ τ otherwise. Entries whose hold block
    /// ends before τ are always free. O(n̲_y n̲_u).
    pub fn causal_mask(&self, strictly_proper: bool) -> DMatrix<bool> {
        DMatrix::from_fn(self.outputs.len(), self.inputs.len(), |i, j| {
            let tau = self.outputs[i].time;
            let t = self.inputs[j].time;
            if strictly_proper { t < tau } else { t <= tau }
        })
    }

    /// The lifted signal of the fast signal `x` (`rows` frames): column c is
    /// channel `slots[c].channel` at the instant `slots[c].time` of each frame.
    fn gather(&self, x: &DMatrix<f64>, slots: &[Slot], rows: usize) -> DMatrix<f64> {
        let j = self.period;
        DMatrix::from_fn(rows, slots.len(), |k, col| {
            let s = slots[col];
            x[(k * j + s.time, s.channel)]
        })
    }

    fn check_len(&self, len: usize) -> Result<usize> {
        if len == 0 {
            return Err(Error::TooShort {
                what: "record",
                got: 0,
                needed: self.period,
            });
        }
        if !len.is_multiple_of(self.period) {
            return Err(Error::LengthNotMultiple {
                len,
                period: self.period,
            });
        }
        Ok(len / self.period)
    }

    /// Lifts fast inputs (N×n_u, held values repeated) to (N/J)×Σ J/m_c.
    /// Errors: wrong column count, N not a multiple of J
    /// ([`Error::LengthNotMultiple`]), non-finite input. O(N n_u).
    pub fn lift_inputs(&self, u: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_columns("fast inputs", u, self.n_inputs())?;
        check_finite("u", u)?;
        let rows = self.check_len(u.nrows())?;
        Ok(self.gather(u, &self.inputs, rows))
    }

    /// Lifts fast outputs (N×n_y, NaN allowed off the sampling instants) to
    /// (N/J)×Σ J/J_o. Errors: as [`Self::lift_inputs`]; a NaN at a sampled
    /// instant is [`Error::NonFinite`]. O(N n_y).
    pub fn lift_outputs(&self, y: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_columns("fast outputs", y, self.n_outputs())?;
        let rows = self.check_len(y.nrows())?;
        let out = self.gather(y, &self.outputs, rows);
        check_finite("y at a sampling instant", &out)?;
        Ok(out)
    }

    /// Inverse lifting of inputs: (K)×Σ J/m_c → (KJ)×n_u with each value
    /// repeated over its hold. O(KJ n_u).
    pub fn unlift_inputs(&self, ul: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_columns("lifted inputs", ul, self.inputs.len())?;
        let j = self.period;
        let mut u = DMatrix::zeros(ul.nrows() * j, self.n_inputs());
        for k in 0..ul.nrows() {
            for (col, s) in self.inputs.iter().enumerate() {
                let h = self.holds[s.channel];
                for t in s.time..s.time + h {
                    u[(k * j + t, s.channel)] = ul[(k, col)];
                }
            }
        }
        Ok(u)
    }

    /// Inverse lifting of outputs: (K)×Σ J/J_o → (KJ)×n_y with NaN at the
    /// instants a channel does not sample. O(KJ n_y).
    pub fn unlift_outputs(&self, yl: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        check_columns("lifted outputs", yl, self.outputs.len())?;
        let j = self.period;
        let mut y = DMatrix::from_element(yl.nrows() * j, self.n_outputs(), f64::NAN);
        for k in 0..yl.nrows() {
            for (col, s) in self.outputs.iter().enumerate() {
                y[(k * j + s.time, s.channel)] = yl[(k, col)];
            }
        }
        Ok(y)
    }

    /// Lifts a data set with this lifting's pattern. The data set's holds,
    /// periods and phases must match ([`Error::InvalidRates`] otherwise).
    /// With `truncate`, an incomplete last frame is dropped; without it a
    /// length that is not a multiple of J is [`Error::LengthNotMultiple`].
    pub fn lift_dataset(&self, data: &Dataset, truncate: bool) -> Result<LiftedData> {
        let pattern = Self::from_dataset(data, self.ordering)?;
        if pattern.holds != self.holds
            || pattern.out_periods != self.out_periods
            || pattern.out_offsets != self.out_offsets
        {
            return Err(Error::InvalidRates {
                what: "data set pattern",
                reason: format!(
                    "data holds {:?}, periods {:?}, offsets {:?} differ from the lifting's {:?}, {:?}, {:?}",
                    pattern.holds,
                    pattern.out_periods,
                    pattern.out_offsets,
                    self.holds,
                    self.out_periods,
                    self.out_offsets
                ),
            });
        }
        let len = data.len();
        let keep = if truncate {
            len - len % self.period
        } else {
            len
        };
        if keep == 0 {
            return Err(Error::TooShort {
                what: "record",
                got: len,
                needed: self.period,
            });
        }
        let u = data.u().rows(0, keep).into_owned();
        let y = data.y().rows(0, keep).into_owned();
        Ok(LiftedData {
            u: self.lift_inputs(&u)?,
            y: self.lift_outputs(&y)?,
            lifting: self.clone(),
            ts: lifted_lti::snap_period(data.ts() * self.period as f64),
        })
    }

    /// A [`Dataset`] from fast signals with this pattern (outputs masked to
    /// NaN off their instants; channel names u1…, y1…).
    pub fn dataset(&self, ts: f64, u: DMatrix<f64>, y: DMatrix<f64>) -> Result<Dataset> {
        let inputs = self
            .holds
            .iter()
            .enumerate()
            .map(|(c, &h)| InputChannel::new(format!("u{}", c + 1), h))
            .collect();
        let outputs = self
            .out_periods
            .iter()
            .zip(&self.out_offsets)
            .enumerate()
            .map(|(o, (&p, &off))| OutputChannel::new(format!("y{}", o + 1), p, off))
            .collect();
        Ok(Dataset::from_fast(ts, u, y, inputs, outputs)?)
    }
}

/// Lifted data: u̲ (K×n̲_u), y̲ (K×n̲_y) and the lifting that gives the
/// meaning of their columns.
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedData {
    /// Lifted inputs, one row per frame.
    pub u: DMatrix<f64>,
    /// Lifted outputs, one row per frame.
    pub y: DMatrix<f64>,
    /// The lifting (pattern and ordering).
    pub lifting: MultirateLifting,
    /// Lifted sample period JT (seconds).
    pub ts: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn siso_slots_follow_the_thesis() {
        let l = MultirateLifting::siso(SisoRates::new(2, 3).unwrap()).unwrap();
        assert_eq!(l.period(), 6);
        let t: Vec<usize> = l.input_slots().iter().map(|s| s.time).collect();
        assert_eq!(t, vec![0, 2, 4]);
        let t: Vec<usize> = l.output_slots().iter().map(|s| s.time).collect();
        assert_eq!(t, vec![0, 3]);
        let mask = l.causal_mask(true);
        // thesis (4.19) for (m, n) = (2, 3): [[0,0,0],[D10,D11,0]]
        assert_eq!(
            mask,
            DMatrix::from_row_slice(2, 3, &[false, false, false, true, true, false])
        );
    }

    #[test]
    fn frames_beyond_memory_or_usize_are_rejected() {
        // Coprime periods whose lcm overflows usize: a named error, not a
        // wrapped frame.
        let e = MultirateLifting::new(
            &[4_294_967_291],
            &[4_294_967_279, 4_294_967_231],
            &[0, 0],
            Ordering::ChannelMajor,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                Error::InvalidRates {
                    what: "lifting period",
                    ..
                }
            ),
            "{e}"
        );
        // A frame of 1e6·999_983 base periods: its lifted channels (and
        // the causal mask) would exceed the memory budget.
        let e = MultirateLifting::new(&[1], &[999_983, 1_000_000], &[0, 0], Ordering::ChannelMajor)
            .unwrap_err();
        assert!(
            matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
            "{e}"
        );
        // The same for an explicit period.
        let e =
            MultirateLifting::new_with_period(&[1], &[1], &[0], Ordering::ChannelMajor, 1 << 40)
                .unwrap_err();
        assert!(
            matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
            "{e}"
        );
    }

    #[test]
    fn coprime_is_checked_and_normalised() {
        assert!(matches!(
            SisoRates::new(2, 4),
            Err(Error::NotCoprime { gcd: 2, .. })
        ));
        let (r, g) = SisoRates::normalized(4, 6).unwrap();
        assert_eq!((r.m, r.n, g), (2, 3, 2));
    }

    #[test]
    fn time_major_interleaves() {
        let l = MultirateLifting::mimo(2, &[5, 1], Ordering::TimeMajor).unwrap();
        let s = l.input_slots();
        assert_eq!((s[0].channel, s[0].time), (0, 0));
        assert_eq!((s[1].channel, s[1].time), (1, 0));
        assert_eq!((s[2].channel, s[2].time), (0, 1));
        let o = l.output_slots();
        assert_eq!(o.len(), 6);
        assert_eq!((o[0].channel, o[0].time), (0, 0));
        assert_eq!((o[1].channel, o[1].time), (1, 0));
    }

    #[test]
    fn lift_unlift_roundtrip_and_errors() {
        let l = MultirateLifting::siso(SisoRates::new(2, 3).unwrap()).unwrap();
        let u = DMatrix::from_fn(12, 1, |k, _| (k / 2) as f64);
        let ul = l.lift_inputs(&u).unwrap();
        assert_eq!(ul.shape(), (2, 3));
        assert_eq!(l.unlift_inputs(&ul).unwrap(), u);
        let y = DMatrix::from_fn(12, 1, |k, _| if k % 3 == 0 { k as f64 } else { f64::NAN });
        let yl = l.lift_outputs(&y).unwrap();
        assert_eq!(yl, DMatrix::from_row_slice(2, 2, &[0.0, 3.0, 6.0, 9.0]));
        let back = l.unlift_outputs(&yl).unwrap();
        assert!(back[(1, 0)].is_nan() && back[(3, 0)] == 3.0);
        let short = DMatrix::zeros(11, 1);
        assert!(matches!(
            l.lift_inputs(&short),
            Err(Error::LengthNotMultiple { len: 11, period: 6 })
        ));
        let mut bad = y.clone();
        bad[(3, 0)] = f64::NAN;
        assert!(matches!(l.lift_outputs(&bad), Err(Error::NonFinite { .. })));
    }
}
