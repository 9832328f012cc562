//! One test per rejected input: a named error, never a panic.

use lifted_lti::StateSpace;
use lifted_multirate::{
    Error, ExtractOptions, ExtractionMethod, LiftedArxOptions, LiftedIdOptions, MultirateLifting,
    Ordering, SisoRates, delay_interval, extract_fast, identify_lifted, lift_model, lifted_arx,
    lifted_impulse_response,
};
use lifted_subspace::OrderSelection;
use nalgebra::DMatrix;

fn fast() -> StateSpace {
    StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap()
}

#[test]
fn not_coprime_is_an_error_and_normalisation_is_explicit() {
    assert!(matches!(
        SisoRates::new(2, 6),
        Err(Error::NotCoprime { m: 2, n: 6, gcd: 2 })
    ));
    assert!(matches!(
        SisoRates::new(0, 3),
        Err(Error::InvalidRates { .. })
    ));
    let (r, g) = SisoRates::normalized(2, 6).unwrap();
    assert_eq!((r.m, r.n, g), (1, 3, 2));
}

#[test]
fn length_not_multiple_and_truncation() {
    let l = MultirateLifting::siso(SisoRates::new(2, 3).unwrap()).unwrap();
    let u = DMatrix::from_fn(14, 1, |k, _| (k / 2) as f64);
    assert!(matches!(
        l.lift_inputs(&u),
        Err(Error::LengthNotMultiple { len: 14, period: 6 })
    ));
    let y = DMatrix::from_fn(14, 1, |k, _| k as f64);
    let ds = l.dataset(1.0, u, y).unwrap();
    assert!(matches!(
        l.lift_dataset(&ds, false),
        Err(Error::LengthNotMultiple { .. })
    ));
    let ld = l.lift_dataset(&ds, true).unwrap();
    assert_eq!(ld.u.nrows(), 2);
}

#[test]
fn nan_is_rejected() {
    let l = MultirateLifting::siso(SisoRates::new(1, 2).unwrap()).unwrap();
    let mut u = DMatrix::from_element(4, 1, 1.0);
    u[(2, 0)] = f64::NAN;
    assert!(matches!(l.lift_inputs(&u), Err(Error::NonFinite { .. })));
    let mut ul = DMatrix::from_element(30, 2, 1.0);
    ul[(3, 1)] = f64::NAN;
    let yl = DMatrix::from_element(30, 1, 1.0);
    assert!(matches!(
        lifted_impulse_response(&ul, &yl, 3),
        Err(Error::NonFinite { .. })
    ));
    let y = DMatrix::from_element(30, 1, f64::NAN);
    assert!(matches!(
        lifted_arx(
            &y,
            &DMatrix::from_element(30, 2, 1.0),
            None,
            &LiftedArxOptions::default()
        ),
        Err(Error::NonFinite { .. })
    ));
}

#[test]
fn order_too_high() {
    let l = MultirateLifting::siso(SisoRates::new(1, 2).unwrap()).unwrap();
    let k = 40;
    let u = DMatrix::from_fn(
        2 * k,
        1,
        |t, _| if (t * 7919 % 13) < 6 { 1.0 } else { -1.0 },
    );
    let y = fast().lsim(&u, None, None).unwrap().y;
    let ds = l.dataset(1.0, u, y).unwrap();
    let ld = l.lift_dataset(&ds, false).unwrap();
    let opts = LiftedIdOptions {
        order: OrderSelection::Fixed(50),
        past: 4,
        future: 4,
        ..Default::default()
    };
    let r = identify_lifted(&ld, &opts);
    assert!(
        matches!(
            r,
            Err(Error::Subspace(
                lifted_subspace::Error::OrderTooLarge { .. }
            ))
        ),
        "{r:?}"
    );
    let arx = lifted_arx(
        &DMatrix::from_element(10, 1, 1.0),
        &DMatrix::from_element(10, 3, 1.0),
        None,
        &LiftedArxOptions {
            na: 4,
            nb: 3,
            ..Default::default()
        },
    );
    assert!(matches!(arx, Err(Error::OrderTooLarge { .. })));
}

#[test]
fn inconsistent_delay_matrix() {
    // l_ij that no single delay can produce
    let l = DMatrix::from_row_slice(2, 3, &[1usize, 3, 1, 3, 1, 3]);
    assert!(matches!(
        delay_interval(&l, SisoRates::new(2, 3).unwrap()),
        Err(Error::DelayInconsistent { .. })
    ));
    let wrong = DMatrix::from_row_slice(1, 1, &[1usize]);
    assert!(matches!(
        delay_interval(&wrong, SisoRates::new(2, 3).unwrap()),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn extraction_rejects_wrong_shapes_and_negative_real_eigenvalues() {
    let l = MultirateLifting::siso(SisoRates::new(1, 2).unwrap()).unwrap();
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, -0.5),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    // lifted with n = 3: Ā = −0.125, whose principal square root (n = 2 lifting) does not exist
    let l3 = MultirateLifting::siso(SisoRates::new(1, 3).unwrap()).unwrap();
    let lm3 = lift_model(&g, &l3).unwrap();
    assert!(matches!(
        extract_fast(&lm3, &l, &ExtractOptions::default()),
        Err(Error::DimensionMismatch { .. })
    ));
    let l3b =
        MultirateLifting::new_with_period(&[1], &[3], &[0], Ordering::ChannelMajor, 6).unwrap();
    let lm = lift_model(&g, &l3b).unwrap(); // Ā = (−0.5)^6 > 0: fine
    assert!(extract_fast(&lm, &l3b, &ExtractOptions::default()).is_ok());
    let l1 = MultirateLifting::siso(SisoRates::new(1, 3).unwrap()).unwrap();
    let bad = lift_model(&g, &l1).unwrap(); // Ā = −0.125
    assert!(matches!(
        extract_fast(&bad, &l1, &ExtractOptions::default()),
        Err(Error::NoPrincipalRoot { root: 3, .. })
    ));
    // eigenvalue approach needs two slots
    let l11 = MultirateLifting::siso(SisoRates::new(1, 1).unwrap()).unwrap();
    let lm11 = lift_model(&fast(), &l11).unwrap();
    let opts = ExtractOptions {
        method: ExtractionMethod::Eigenvalue,
        ..Default::default()
    };
    assert!(matches!(
        extract_fast(&lm11, &l11, &opts),
        Err(Error::EigenApproach { .. })
    ));
    // polyphase needs m = 1
    let l23 = MultirateLifting::siso(SisoRates::new(2, 3).unwrap()).unwrap();
    let lm23 = lift_model(&fast(), &l23).unwrap();
    let opts = ExtractOptions {
        method: ExtractionMethod::Polyphase,
        ..Default::default()
    };
    assert!(matches!(
        extract_fast(&lm23, &l23, &opts),
        Err(Error::Unsupported { .. })
    ));
}

#[test]
fn continuous_model_cannot_be_lifted() {
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, -1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        None,
    )
    .unwrap();
    let l = MultirateLifting::siso(SisoRates::new(1, 2).unwrap()).unwrap();
    assert!(matches!(lift_model(&g, &l), Err(Error::Unsupported { .. })));
}
