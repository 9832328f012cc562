//! The procedure of §4.7 end to end on noise-free data.

use lifted_lti::{C2dOptions, TransferFunction};
use lifted_multirate::{
    DelayHandling, LiftedIdOptions, MultirateLifting, ProcedureOptions, SisoRates,
    identify_multirate,
};
use lifted_subspace::OrderSelection;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn delay_shift_identify_extract_noise_free() {
    // e^{-5s}/(20s+1) at T = 1, hold 2, sampling 3 (thesis §4.8 without noise)
    let g = TransferFunction::from_coeffs(&[1.0], &[20.0, 1.0], None)
        .unwrap()
        .to_ss()
        .unwrap();
    let opts = C2dOptions {
        input_delays: Some(vec![5.0]),
        ..Default::default()
    };
    let plant = g.c2d(1.0, &opts).unwrap();
    let lifting = MultirateLifting::siso(SisoRates::new(2, 3).unwrap()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let k = 600;
    let ul = DMatrix::from_fn(k, 3, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let u = lifting.unlift_inputs(&ul).unwrap();
    let y = plant.lsim(&u, None, None).unwrap().y;
    let ds = lifting.dataset(1.0, u, y).unwrap();
    let popts = ProcedureOptions {
        delay: DelayHandling::Estimate {
            lags: 4,
            sigmas: 3.0,
        },
        identification: LiftedIdOptions {
            order: OrderSelection::Fixed(1),
            past: 4,
            future: 4,
            ..Default::default()
        },
        ..Default::default()
    };
    let fit = identify_multirate(&ds, None, &popts).unwrap();
    let iv = fit.delay_interval.unwrap();
    assert_eq!((iv.lower, iv.upper), (5, 6));
    assert_eq!(fit.shift, (1, 1));
    let p = (-0.1f64).exp();
    assert!((fit.fast.poles().unwrap()[0].re - p).abs() < 1e-8);
    assert!((fit.fast.dc_gain().unwrap()[(0, 0)] - 1.0).abs() < 1e-8);
    assert_eq!(fit.fast.ts(), Some(2.0));
    // 5 is not a multiple of the hold 2: the delay cannot be re-inserted as z^{-k} (L-10)
    assert!(fit.fast_with_delay().is_err());
}
