use super::*;
use crate::lagged::KERNEL_BLOCK;

fn explicit_gram(
    recs: &[(&DMatrix<f64>, &DMatrix<f64>)],
    lay: &HankelLayout,
) -> (DMatrix<f64>, usize) {
    let k = lay.nrows();
    let src = lay.sources();
    let mut g = DMatrix::zeros(k, k);
    let mut total = 0;
    for (u, y) in recs {
        let at = |ch: usize, t: usize| {
            if ch < lay.nu {
                u[(t, ch)]
            } else {
                y[(t, ch - lay.nu)]
            }
        };
        let j = lay.columns(u.nrows());
        let h = DMatrix::from_fn(k, j, |r, c| at(src[r].1, c + src[r].0));
        g += &h * h.transpose();
        total += j;
    }
    (g / total as f64, total)
}

/// Pseudo-random data (64-bit LCG), full rank Hankel matrices.
fn data(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let u = DMatrix::from_fn(n, 2, |_, _| next());
    let y = DMatrix::from_fn(n, 1, |_, _| next());
    (u, y)
}

#[test]
fn both_compressions_match_the_explicit_hankel_gram() {
    let lay = HankelLayout {
        past: 3,
        future: 2,
        nu: 2,
        ny: 1,
    };
    let (u1, y1) = data(57, 0);
    let (u2, y2) = data(23, 5);
    let recs = [(&u1, &y1), (&u2, &y2)];
    let (g, j) = explicit_gram(&recs, &lay);
    assert_eq!(j, 53 + 19);
    for mode in [Compression::Qr, Compression::Correlation] {
        let f = compress(&recs, &lay, mode, 7, 1, Scale::ONE, false).unwrap();
        assert_eq!(f.columns, j);
        assert_eq!(f.report.used, mode);
        let g2 = &f.l * f.l.transpose();
        assert!((&g - g2).norm() < 1e-10 * g.norm(), "{mode:?}");
    }
    // Ordering: the first U_f row at the first column is u(past, 0).
    assert_eq!(lay.sources()[lay.uf().start], (3, 0));
    assert_eq!(lay.sources()[lay.yp().start], (0, 2));
    assert_eq!(lay.sources()[lay.yf().start], (3, 2));
}

#[test]
fn streaming_blocks_of_any_size_give_the_same_factor() {
    let lay = HankelLayout {
        past: 4,
        future: 3,
        nu: 2,
        ny: 1,
    };
    let (u, y) = data(300, 1);
    let whole = compress(
        &[(&u, &y)],
        &lay,
        Compression::Correlation,
        64,
        1,
        Scale::ONE,
        false,
    )
    .unwrap();
    for (b, threads) in [(1usize, 1usize), (5, 1), (6, 2), (299, 1)] {
        for mode in [Compression::Correlation, Compression::Qr] {
            let mut st = HankelStream::new(lay, mode, 17, threads);
            let mut s = 0;
            while s < 300 {
                let len = b.min(300 - s);
                st.push(u.rows(s, len), y.rows(s, len)).unwrap();
                s += len;
            }
            let f = st.finish().unwrap();
            let (g1, g2) = (&whole.l * whole.l.transpose(), &f.l * f.l.transpose());
            assert!((&g1 - g2).norm() < 1e-10 * g1.norm(), "b {b} {mode:?}");
        }
    }
}

#[test]
fn parallel_sums_equal_sequential() {
    let n = 3 * KERNEL_BLOCK + 77;
    let a: Vec<f64> = (0..n).map(|i| ((i * 37) % 19) as f64 - 9.0).collect();
    let b: Vec<f64> = (0..n).map(|i| ((i * 11) % 23) as f64 - 11.0).collect();
    let span = 6;
    let len = n - span + 1;
    let mut s1 = vec![0.0; span * 4];
    let mut s2 = vec![0.0; span * 4];
    let ch = [Channel::plain(&a), Channel::plain(&b)];
    let mut one = [Scratch::default()];
    channel_sums_par(&ch, span, len, &mut s1, 1, &mut one);
    let mut work = [Scratch::default(), Scratch::default()];
    channel_sums_par(&ch, span, len, &mut s2, 2, &mut work);
    // Integer data: all sums exact in both orders.
    assert_eq!(s1, s2);
    let want: f64 = (0..len).map(|t| a[t] * b[t + 5]).sum();
    assert_eq!(s1[(5 * 2) * 2 + 1], want);
}

#[test]
fn rank_deficient_data_falls_back_to_qr() {
    let lay = HankelLayout {
        past: 3,
        future: 3,
        nu: 1,
        ny: 1,
    };
    // y = u delayed: the Hankel rows are linearly dependent.
    let u = DMatrix::from_fn(200, 1, |i, _| ((i * 7919) % 101) as f64 / 50.0 - 1.0);
    let y = DMatrix::from_fn(200, 1, |i, _| if i > 0 { u[(i - 1, 0)] } else { 0.0 });
    let f = compress(
        &[(&u, &y)],
        &lay,
        Compression::Auto,
        64,
        1,
        Scale::ONE,
        false,
    )
    .unwrap();
    assert_eq!(f.report.used, Compression::Qr);
    assert!(f.report.fallback.is_some());
    assert!(matches!(
        compress(
            &[(&u, &y)],
            &lay,
            Compression::Correlation,
            64,
            1,
            Scale::ONE,
            false
        ),
        Err(Error::IllConditionedCorrelation { .. })
    ));
}
