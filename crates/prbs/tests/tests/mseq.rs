use lifted_prbs::{MSequence, Normalization, is_primitive, periodic_autocorrelation, table_taps};

/// Zhu 2000 Table I / Ren & Zhu 2009 Table 1 (spec A1.1), plus 12 and 13 of A1.1.
const TABLE_I: [(u32, &[u32]); 12] = [
    (2, &[1, 2]),
    (3, &[2, 3]),
    (4, &[3, 4]),
    (5, &[3, 5]),
    (6, &[5, 6]),
    (7, &[4, 7]),
    (8, &[2, 3, 4, 8]),
    (9, &[5, 9]),
    (10, &[7, 10]),
    (11, &[9, 11]),
    (12, &[6, 8, 11, 12]),
    (13, &[9, 10, 12, 13]),
];

#[test]
fn table_i_taps() {
    for (n, taps) in TABLE_I {
        assert_eq!(table_taps(n).unwrap(), taps, "order {n}");
        assert_eq!(MSequence::new(n).unwrap().taps(), taps);
    }
}

#[test]
fn golden_prefixes() {
    let bits = |n: u32, len: usize| -> String {
        MSequence::new(n)
            .unwrap()
            .take(len)
            .map(|b| char::from(b'0' + b))
            .collect()
    };
    assert_eq!(bits(3, 7), "1011100");
    assert_eq!(bits(5, 31), "1001011001111100011011101010000");
}

/// Orders 2..=20 exhaustively: the register state first returns to its initial
/// value after exactly m steps; 2^{n−1} ones per period; the ±1 sequence has the
/// two-valued periodic autocorrelation (m at lag 0, −1 at every other lag) —
/// integer sums for n ≤ 11, FFT (rounded; error ≪ 0.5) for 12 ≤ n ≤ 20.
#[test]
fn exhaustive_period_and_two_valued_autocorrelation() {
    for n in 2..=20u32 {
        let m = (1usize << n) - 1;
        let mut reg = MSequence::new(n).unwrap();
        let init = reg.state();
        let mut bits = Vec::with_capacity(m);
        for k in 0..m {
            if k > 0 {
                assert_ne!(reg.state(), init, "order {n}: early return at {k}");
            }
            bits.push(reg.next_bit());
        }
        assert_eq!(reg.state(), init, "order {n}: not back after m steps");
        let ones = bits.iter().filter(|&&b| b == 1).count();
        assert_eq!(ones, 1 << (n - 1), "order {n}");
        if n <= 11 {
            let s: Vec<i64> = bits.iter().map(|&b| 1 - 2 * b as i64).collect();
            for tau in 0..m {
                let r: i64 = (0..m).map(|k| s[(k + tau) % m] * s[k]).sum();
                assert_eq!(r, if tau == 0 { m as i64 } else { -1 }, "n {n} tau {tau}");
            }
        } else {
            let s: Vec<f64> = bits.iter().map(|&b| 1.0 - 2.0 * b as f64).collect();
            let r = periodic_autocorrelation(&s, Normalization::Sum).unwrap();
            for (tau, v) in r.iter().enumerate() {
                let expect = if tau == 0 { m as f64 } else { -1.0 };
                assert!((v - expect).abs() < 1e-3, "n {n} tau {tau}: {v}");
            }
        }
    }
}

/// Orders 2..=32: the characteristic polynomial is primitive (x^m ≡ 1, x^{m/q} ≢ 1
/// for every prime q | m), and the register state jumped ahead by m equals the
/// initial state while a jump by m/q does not.
#[test]
fn all_orders_have_period_m_on_the_register_state() {
    for n in 2..=32u32 {
        let reg = MSequence::new(n).unwrap();
        let p = reg.polynomial();
        assert!(is_primitive(p), "order {n} polynomial {p:#x} not primitive");
        assert!(reg.is_maximal());
        let m = reg.period();
        assert_eq!(m, (1u64 << n) - 1);
        let mut jumped = reg.clone();
        jumped.advance(m);
        assert_eq!(jumped.state(), reg.state(), "order {n}");
        let mut q = 2u64;
        let mut rest = m;
        while q * q <= rest {
            if rest.is_multiple_of(q) {
                let mut j = reg.clone();
                j.advance(m / q);
                assert_ne!(j.state(), reg.state(), "order {n}, m/{q}");
                while rest.is_multiple_of(q) {
                    rest /= q;
                }
            }
            q += 1;
        }
        if rest > 1 {
            let mut j = reg.clone();
            j.advance(m / rest);
            assert_ne!(j.state(), reg.state(), "order {n}, m/{rest}");
        }
    }
}

#[test]
fn non_primitive_taps_are_detected() {
    // x^4 + x^2 + 1 is reducible: period 6, not 15.
    let reg = MSequence::with_taps(4, &[2, 4]).unwrap();
    assert!(!reg.is_maximal());
    let mut r = reg.clone();
    r.advance(6);
    assert_eq!(r.state(), reg.state());
}

#[test]
fn word_parallel_agrees_with_fibonacci() {
    for n in 2..=32u32 {
        let reg = MSequence::new(n).unwrap();
        let mut serial = reg.clone();
        let mut words = reg.into_words();
        let nwords = 2 * n as usize + 40;
        for t in 0..nwords {
            let w = words.next_word();
            for j in 0..64 {
                assert_eq!(
                    ((w >> j) & 1) as u8,
                    serial.next_bit(),
                    "order {n}, bit {}",
                    64 * t + j
                );
            }
        }
    }
}

#[test]
fn word_parallel_agrees_after_advance() {
    let mut reg = MSequence::new(17).unwrap();
    reg.advance(123_457);
    let mut serial = reg.clone();
    let mut words = reg.into_words();
    for _ in 0..100 {
        let w = words.next_word();
        for j in 0..64 {
            assert_eq!(((w >> j) & 1) as u8, serial.next_bit());
        }
    }
}
