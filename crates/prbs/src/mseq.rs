//! Maximum-length sequences (m-sequences), Zhu 2000 eqs. (II-1)–(II-3) and Table I.
//!
//! The bits obey `b(k+1) = XOR_{i∈S_n} b(k+1−i)` with `b(0) = 1` and
//! `b(−1) = … = b(−(n−1)) = 0` (spec A1.1; erratum RZ-1: only `n−1` past zeros are
//! needed). The characteristic polynomial is `C(x) = xⁿ + Σ_{i∈S, i<n} x^{n−i} + 1`;
//! the sequence has period `m = 2ⁿ − 1` exactly when `C` is primitive over GF(2).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Smallest supported order.
pub const MIN_ORDER: u32 = 2;
/// Largest supported order.
pub const MAX_ORDER: u32 = 32;

/// Feedback taps `S_n` for orders 2..=32 (index `n − 2`).
///
/// Orders 2..=11 are exactly Zhu 2000 Table I / Ren & Zhu 2009 Table 1 (the
/// "non-negative coefficients" `a_i`); 12 and 13 are the extension of spec A1.1;
/// 14..=32 are standard primitive trinomials/pentanomials (the tests verify the
/// primitivity of every entry algebraically).
const TAPS: [&[u32]; 31] = [
    &[1, 2],           // 2
    &[2, 3],           // 3
    &[3, 4],           // 4
    &[3, 5],           // 5
    &[5, 6],           // 6
    &[4, 7],           // 7
    &[2, 3, 4, 8],     // 8
    &[5, 9],           // 9
    &[7, 10],          // 10
    &[9, 11],          // 11
    &[6, 8, 11, 12],   // 12 (spec A1.1)
    &[9, 10, 12, 13],  // 13 (spec A1.1)
    &[1, 3, 5, 14],    // 14
    &[14, 15],         // 15
    &[4, 13, 15, 16],  // 16
    &[14, 17],         // 17
    &[11, 18],         // 18
    &[1, 2, 6, 19],    // 19
    &[17, 20],         // 20
    &[19, 21],         // 21
    &[21, 22],         // 22
    &[18, 23],         // 23
    &[17, 22, 23, 24], // 24
    &[22, 25],         // 25
    &[1, 2, 6, 26],    // 26
    &[1, 2, 5, 27],    // 27
    &[25, 28],         // 28
    &[27, 29],         // 29
    &[1, 4, 6, 30],    // 30
    &[28, 31],         // 31
    &[1, 2, 22, 32],   // 32
];

/// The feedback taps `S_n` of the built-in table for `order` (Table I for 2..=11).
///
/// # Errors
/// [`Error::OrderOutOfRange`] unless `2 ≤ order ≤ 32`.
pub fn table_taps(order: u32) -> Result<&'static [u32]> {
    check_order(order)?;
    Ok(TAPS[(order - MIN_ORDER) as usize])
}

/// The period `m = 2ⁿ − 1` of an order-`n` m-sequence.
///
/// # Errors
/// [`Error::OrderOutOfRange`] unless `2 ≤ order ≤ 32`.
pub fn period(order: u32) -> Result<u64> {
    check_order(order)?;
    Ok((1u64 << order) - 1)
}

pub(crate) fn check_order(order: u32) -> Result<()> {
    if (MIN_ORDER..=MAX_ORDER).contains(&order) {
        Ok(())
    } else {
        Err(Error::OrderOutOfRange {
            order,
            min: MIN_ORDER,
            max: MAX_ORDER,
        })
    }
}

/// Characteristic polynomial `C(x) = xⁿ + Σ_{i∈S, i<n} x^{n−i} + 1` as a bit mask
/// (bit `j` is the coefficient of `x^j`). Taps must already be validated.
pub(crate) fn characteristic_polynomial(order: u32, taps: &[u32]) -> u64 {
    let mut p = 1u64 << order;
    for &i in taps {
        p ^= 1u64 << (order - i);
    }
    p
}

/// Degree of a nonzero GF(2) polynomial.
fn degree(p: u64) -> u32 {
    63 - p.leading_zeros()
}

/// `a · b mod p` over GF(2), with `deg a, deg b < deg p ≤ 32`. O(deg p).
fn mulmod(a: u64, b: u64, p: u64) -> u64 {
    let n = degree(p);
    let mut acc = 0u64;
    let mut a = a;
    let mut b = b;
    while b != 0 {
        if b & 1 == 1 {
            acc ^= a;
        }
        b >>= 1;
        a <<= 1;
        if (a >> n) & 1 == 1 {
            a ^= p;
        }
    }
    acc
}

/// `x^e mod p` over GF(2) by square-and-multiply, `2 ≤ deg p ≤ 32`.
/// O(deg p · log e) word operations.
pub(crate) fn x_pow_mod(e: u64, p: u64) -> u64 {
    let mut result = 1u64;
    let mut base = 2u64; // x, of degree 1 < deg p
    let mut e = e;
    while e != 0 {
        if e & 1 == 1 {
            result = mulmod(result, base, p);
        }
        base = mulmod(base, base, p);
        e >>= 1;
    }
    result
}

/// Distinct prime factors of `v` by trial division. O(√v).
fn prime_factors(mut v: u64) -> Vec<u64> {
    let mut out = Vec::new();
    let mut d = 2u64;
    while d * d <= v {
        if v.is_multiple_of(d) {
            out.push(d);
            while v.is_multiple_of(d) {
                v /= d;
            }
        }
        d += 1;
    }
    if v > 1 {
        out.push(v);
    }
    out
}

/// Whether the degree-`n` GF(2) polynomial `p` (bit mask, `1 ≤ n ≤ 32`) is primitive:
/// `x^(2ⁿ−1) ≡ 1 (mod p)` and `x^((2ⁿ−1)/q) ≢ 1` for every prime `q | 2ⁿ−1`.
///
/// This is the cheap certificate that an LFSR with characteristic polynomial `p`
/// has period exactly `2ⁿ − 1` from any nonzero state. Cost O(n · (n + √(2ⁿ))).
pub fn is_primitive(p: u64) -> bool {
    if p < 2 || p & 1 == 0 {
        return false;
    }
    let n = degree(p);
    if n > MAX_ORDER {
        return false;
    }
    let m = (1u64 << n) - 1;
    if x_pow_mod(m, p) != 1 {
        return false;
    }
    prime_factors(m)
        .into_iter()
        .all(|q| x_pow_mod(m / q, p) != 1)
}

/// Bit-exact Fibonacci shift register producing an m-sequence (spec A1.1).
///
/// `state` bit `j` holds `b(k − j)`, `j = 0..n`; the iterator yields `b(k)` and steps.
/// Each sample costs O(1) (one AND, one popcount) and allocates nothing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MSequence {
    order: u32,
    taps: Vec<u32>,
    tap_mask: u64,
    state_mask: u64,
    state: u64,
    index: u64,
}

impl MSequence {
    /// The order-`n` m-sequence with the built-in taps (Table I for `n ≤ 11`),
    /// started at `b(0) = 1`, `b(−1..−(n−1)) = 0`.
    ///
    /// # Errors
    /// [`Error::OrderOutOfRange`] unless `2 ≤ order ≤ 32`.
    pub fn new(order: u32) -> Result<Self> {
        Self::with_taps(order, table_taps(order)?)
    }

    /// A register with user taps `S` (each in `1..=order`, distinct, containing `order`).
    /// Whether the result is maximal is reported by [`MSequence::is_maximal`].
    ///
    /// # Errors
    /// [`Error::OrderOutOfRange`], [`Error::InvalidTaps`].
    pub fn with_taps(order: u32, taps: &[u32]) -> Result<Self> {
        check_order(order)?;
        let bad = |reason| Error::InvalidTaps {
            order,
            taps: taps.to_vec(),
            reason,
        };
        if !taps.contains(&order) {
            return Err(bad("the top tap equal to the order is missing"));
        }
        let mut tap_mask = 0u64;
        for &i in taps {
            if i == 0 || i > order {
                return Err(bad("a tap lies outside 1..=order"));
            }
            let bit = 1u64 << (i - 1);
            if tap_mask & bit != 0 {
                return Err(bad("a tap is repeated"));
            }
            tap_mask |= bit;
        }
        let mut sorted = taps.to_vec();
        sorted.sort_unstable();
        let state_mask = (1u64 << order) - 1;
        Ok(Self {
            order,
            taps: sorted,
            tap_mask,
            state_mask,
            state: 1,
            index: 0,
        })
    }

    /// Order `n`.
    pub fn order(&self) -> u32 {
        self.order
    }

    /// Feedback taps `S_n`, ascending.
    pub fn taps(&self) -> &[u32] {
        &self.taps
    }

    /// Period `m = 2ⁿ − 1` of a maximal sequence of this order.
    pub fn period(&self) -> u64 {
        (1u64 << self.order) - 1
    }

    /// Characteristic polynomial `C(x) = xⁿ + Σ_{i∈S, i<n} x^{n−i} + 1` as a bit mask
    /// (bit `j` is the coefficient of `x^j`).
    pub fn polynomial(&self) -> u64 {
        characteristic_polynomial(self.order, &self.taps)
    }

    /// Whether the taps give a maximal-length sequence (primitive polynomial).
    pub fn is_maximal(&self) -> bool {
        is_primitive(self.polynomial())
    }

    /// Register state: bit `j` is `b(k − j)` for the next output `b(k)`.
    pub fn state(&self) -> u64 {
        self.state
    }

    /// Index `k` of the next output bit.
    pub fn position(&self) -> u64 {
        self.index
    }

    /// Next bit `b(k)` (0 or 1) and one register step. O(1).
    #[inline]
    pub fn next_bit(&mut self) -> u8 {
        let out = (self.state & 1) as u8;
        let fb = (self.state & self.tap_mask).count_ones() as u64 & 1;
        self.state = ((self.state << 1) | fb) & self.state_mask;
        self.index = self.index.wrapping_add(1);
        out
    }

    /// Jumps `steps` samples ahead without stepping through them (the register
    /// state after `steps` steps), using `x^steps mod C(x)`. O(n · log steps).
    pub fn advance(&mut self, steps: u64) {
        let n = self.order as usize;
        // Bits b(base .. base + 2n − 1), base = k − n + 1.
        let mut window = 0u64;
        for j in 0..n {
            window |= ((self.state >> (n - 1 - j)) & 1) << j;
        }
        let mut probe = self.clone();
        probe.next_bit();
        for j in n..2 * n - 1 {
            window |= (probe.state & 1) << j;
            probe.next_bit();
        }
        // b(base + steps + t) = Σ_j c_j b(base + j + t).
        let c = x_pow_mod(steps, self.polynomial());
        let mut state = 0u64;
        for t in 0..n {
            let bit = ((window >> t) & c).count_ones() as u64 & 1;
            // new state bit (n − 1 − t) holds b(k' − (n−1−t)) = b(base' + t).
            state |= bit << (n - 1 - t);
        }
        self.state = state;
        self.index = self.index.wrapping_add(steps);
    }

    /// Fills `out` with the next bits (0/1), bit-serial. O(len).
    pub fn fill_bits(&mut self, out: &mut [u8]) {
        for b in out.iter_mut() {
            *b = self.next_bit();
        }
    }

    /// Word-parallel generator of the following bits, 64 per step (see [`WordGenerator`]).
    /// Consumes the register.
    pub fn into_words(self) -> WordGenerator {
        WordGenerator::new(self)
    }
}

impl Iterator for MSequence {
    type Item = u8;

    #[inline]
    fn next(&mut self) -> Option<u8> {
        Some(self.next_bit())
    }
}

/// Word-parallel m-sequence generator: 64 bits per step.
///
/// Over GF(2), `C(x)^64 = C(x^64)`, so the bits also obey
/// `b(k) = XOR_{i∈S} b(k − 64 i)`. With words `W_t` holding `b(64t + j)` in bit `j`,
/// this is `W_t = XOR_{i∈S} W_{t−i}`: |S| XORs per 64 bits. The first `n` words are
/// produced by the bit-exact Fibonacci register; tests check both forms agree.
#[derive(Debug, Clone)]
pub struct WordGenerator {
    ring: [u64; 64],
    taps: Vec<u32>,
    order: usize,
    t: usize,
}

impl WordGenerator {
    fn new(mut reg: MSequence) -> Self {
        let n = reg.order as usize;
        let mut ring = [0u64; 64];
        for w in ring.iter_mut().take(n) {
            let mut word = 0u64;
            for j in 0..64 {
                word |= (reg.next_bit() as u64) << j;
            }
            *w = word;
        }
        Self {
            ring,
            taps: reg.taps.clone(),
            order: n,
            t: 0,
        }
    }

    /// Next 64 bits, bit `j` = `b(64t + j)`. O(|S|).
    #[inline]
    pub fn next_word(&mut self) -> u64 {
        let t = self.t;
        let out = self.ring[t & 63];
        // Produce word t + n from words t + n − i.
        let target = t + self.order;
        let mut w = 0u64;
        for &i in &self.taps {
            w ^= self.ring[(target - i as usize) & 63];
        }
        self.ring[target & 63] = w;
        self.t = t + 1;
        out
    }

    /// Fills `out` with the following words.
    pub fn fill_words(&mut self, out: &mut [u64]) {
        for w in out.iter_mut() {
            *w = self.next_word();
        }
    }
}

impl Iterator for WordGenerator {
    type Item = u64;

    #[inline]
    fn next(&mut self) -> Option<u64> {
        Some(self.next_word())
    }
}

/// Serializable description of an m-sequence generator (order and taps).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MSequenceSpec {
    /// Order `n`; default 8 (Zhu 2000 Table II).
    pub order: u32,
    /// Feedback taps `S_n`; `None` (default) uses the built-in table (Table I, eq. II-1).
    pub taps: Option<Vec<u32>>,
}

impl Default for MSequenceSpec {
    fn default() -> Self {
        Self {
            order: 8,
            taps: None,
        }
    }
}

impl MSequenceSpec {
    /// Builds the validated register.
    ///
    /// # Errors
    /// As [`MSequence::with_taps`].
    pub fn build(&self) -> Result<MSequence> {
        match &self.taps {
            Some(t) => MSequence::with_taps(self.order, t),
            None => MSequence::new(self.order),
        }
    }
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn golden_prefix_order3() {
        let bits: Vec<u8> = MSequence::new(3).unwrap().take(7).collect();
        assert_eq!(bits, [1, 0, 1, 1, 1, 0, 0]);
    }

    #[test]
    fn factorization() {
        assert_eq!(prime_factors(255), vec![3, 5, 17]);
        assert_eq!(prime_factors((1u64 << 32) - 1), vec![3, 5, 17, 257, 65537]);
        assert_eq!(prime_factors(2047), vec![23, 89]);
    }

    #[test]
    fn reducible_polynomial_is_not_primitive() {
        // x^4 + x^2 + 1 = (x^2 + x + 1)^2.
        assert!(!is_primitive(0b10101));
        // x^4 + x^3 + x^2 + x + 1: irreducible but of order 5, not 15.
        assert!(!is_primitive(0b11111));
        assert!(is_primitive(0b10011));
        for junk in [0, 1, 2, u64::MAX, 1 << 40 | 1] {
            assert!(!is_primitive(junk));
        }
    }

    #[test]
    fn advance_matches_stepping() {
        let mut a = MSequence::new(7).unwrap();
        let mut b = a.clone();
        for _ in 0..1000 {
            b.next_bit();
        }
        a.advance(1000);
        assert_eq!(a.state(), b.state());
        assert_eq!(a.position(), 1000);
    }
}
