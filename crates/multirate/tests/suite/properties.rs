//! Property tests: lifting identities.

use lifted_multirate::{MultirateLifting, Ordering, lift, unlift};
use nalgebra::DMatrix;
use proptest::prelude::*;

proptest! {
    #[test]
    fn lifting_preserves_norm_and_inverts(n in 1usize..8, frames in 1usize..12, ch in 1usize..4, seed in 0u64..1000) {
        let x = DMatrix::from_fn(n * frames, ch, |i, j| (((i * 31 + j * 17) as u64 * (seed + 3)) % 101) as f64 - 50.0);
        let xl = lift(&x, n).unwrap();
        prop_assert_eq!(xl.norm(), x.norm());
        prop_assert_eq!(unlift(&xl, n, ch).unwrap(), x);
    }

    #[test]
    fn multirate_lifting_inverts(hold in 1usize..4, period in 1usize..5, frames in 1usize..6, tm in any::<bool>()) {
        let ord = if tm { Ordering::TimeMajor } else { Ordering::ChannelMajor };
        let l = MultirateLifting::new(&[hold, 1], &[period], &[0], ord).unwrap();
        let j = l.period();
        let ul = DMatrix::from_fn(frames, l.lifted_inputs(), |i, c| (i * 7 + c * 3) as f64);
        let u = l.unlift_inputs(&ul).unwrap();
        prop_assert_eq!(u.nrows(), frames * j);
        prop_assert_eq!(l.lift_inputs(&u).unwrap(), ul);
        let yl = DMatrix::from_fn(frames, l.lifted_outputs(), |i, c| (i * 5 + c) as f64);
        let y = l.unlift_outputs(&yl).unwrap();
        prop_assert_eq!(l.lift_outputs(&y).unwrap(), yl);
    }
}
