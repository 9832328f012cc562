//! Multirate identification for Lifted (Li 2001, thesis Ch. 3–7).
//!
//! A multirate sampled-data system — inputs held m_c T, outputs sampled
//! every J_o T — is periodically time varying on the fast grid; lifting over
//! the frame J = lcm(m_c, J_o) makes it LTI (eq. 4.1, 5.1). This crate
//! lifts data and models, estimates the time delay, identifies the lifted
//! model with its causality constraint and extracts the fast single-rate
//! model.
//!
//! # Map
//!
//! | item | what | source |
//! |---|---|---|
//! | [`MultirateLifting`], [`Ordering`], [`SisoRates`], [`lift`]/[`unlift`] | lifting of signals and data sets, recorded column order | §3.1, §4.2, §5.2, §7.5; pitfall 12 |
//! | [`lift_model`], [`siso_lifted_model`], [`lift_single_rate`] | lifted state-space models from a fast model (general D̄ entry) | Prop. 1 (4.5–4.7, L-5), Prop. 4 (L-13), §3.1, lifted noise |
//! | [`observability`], [`condition_one`] | observability of lifted models under delay | §4.3, Prop. 2 |
//! | [`lifted_impulse_response`], [`delay_matrix`], [`delay_interval`], [`shift_split`], [`shift_dataset`] | time-delay estimation, half-open interval, data shift | §4.4, (4.14), L-8, L-10 |
//! | [`identify_lifted`], [`identify_multirate`] ([`ProcedureOptions`]) | causal lifted identification and the whole procedure | §4.5, §4.7, §5.2 |
//! | [`extract_fast`] ([`ExtractionMethod`]) | controllability, eigenvalue, matrix-root, polyphase extraction | §4.6, §5.2.2, §6.2, L-11 |
//! | [`polyphase_components`], [`recombine_lifted_tf`], [`recombine_polyphase_tf`], impulse forms | polyphase identities | §6.2 (6.4, 6.5, L-15), §9.2 |
//! | [`lifted_arx`], [`screen_inputs`] | lifted ARX with causality, CCA input screening | §6.2, §6.4 |
//! | [`identify_lifted_iv`], [`identify_one_step_iv`] | closed-loop multirate IV, two-step and one-step (7.27) | §7.5, L-18 |
//!
//! # Method in brief
//!
//! For hold mT and sampling nT (m, n co-prime), the lifted model of the
//! fast model (A, B, C, D) is Ā = A^{mn}, B̄_j = A_{mT}^{n−1−j}B_{mT},
//! C̄_i = CA^{in}, D̄_ij = C Σ_{s=jm}^{min((j+1)m, in)−1} A^{in−1−s}B +
//! D[jm ≤ in < (j+1)m] (A3.2). A delay d_cT > T destroys observability
//! (Prop. 2), so the delay is estimated from the lifted impulse response to
//! within one base period (4.14) and removed by shifting the data; the
//! lifted model is identified with D̄_ij = 0 for jm ≥ in (4.17) and the fast
//! model is extracted (principal root of Ā needs |nmTη| < π).
//!
//! Costs: lifting O(N(n_u + n_y)); lifted model O(J n³); extraction
//! O(q n³); identification as `lifted-subspace` on N/J frames.
//!
//! # Example
//!
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_multirate::{ExtractOptions, ExtractionMethod, MultirateLifting, SisoRates, extract_fast, lift_model};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // fast model at mT = 2 s of 1/(20s+1): pole e^{-0.1}
//! let p = (-0.1f64).exp();
//! let fast2 = StateSpace::new(
//!     DMatrix::from_element(1, 1, p), DMatrix::from_element(1, 1, 1.0 - p),
//!     DMatrix::from_element(1, 1, 1.0), DMatrix::zeros(1, 1), Some(2.0))?;
//! // the same plant at T = 1 s, then lifted for hold 2 s, sampling 3 s
//! let q = (-0.05f64).exp();
//! let fast1 = StateSpace::new(
//!     DMatrix::from_element(1, 1, q), DMatrix::from_element(1, 1, 1.0 - q),
//!     DMatrix::from_element(1, 1, 1.0), DMatrix::zeros(1, 1), Some(1.0))?;
//! let lifting = MultirateLifting::siso(SisoRates::new(2, 3)?)?;
//! let lifted = lift_model(&fast1, &lifting)?;
//! assert_eq!((lifted.n_inputs(), lifted.n_outputs()), (3, 2));
//! // back to the fast model at the hold period 2 s by the principal cube root
//! let fm = extract_fast(&lifted, &lifting, &ExtractOptions::default())?;
//! assert!((fm.model.a()[(0, 0)] - p).abs() < 1e-12);
//! assert!((fm.model.dc_gain()?[(0, 0)] - fast2.dc_gain()?[(0, 0)]).abs() < 1e-12);
//! // the controllability approach gives the same model
//! let opts = ExtractOptions { method: ExtractionMethod::Controllability, ..Default::default() };
//! assert!((extract_fast(&lifted, &lifting, &opts)?.model.a()[(0, 0)] - p).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

pub mod arx;
pub mod delay;
pub mod error;
pub mod extract;
pub mod identify;
pub mod lifting;
pub mod model;
pub mod polyphase;

pub use arx::{
    InputScore, LiftedArx, LiftedArxOptions, Screening, causal_delays, lifted_arx, screen_inputs,
};
pub use delay::{
    DelayInterval, ImpulseEstimate, delay_bounds, delay_interval, delay_matrix, delay_matrix_exact,
    lifted_fir_estimate, lifted_impulse_response, shift_dataset, shift_split,
};
pub use error::{Error, Result};
pub use extract::{
    ExtractOptions, ExtractionCandidate, ExtractionDiagnostics, ExtractionMethod, FastModel,
    InputMatrix, RESPONSE_FRAMES, extract_fast,
};
pub use identify::{
    DelayHandling, LiftedFit, LiftedIdOptions, LiftedIvModel, LiftedIvOptions, MultirateModel,
    PairDelay, ProcedureOptions, estimate_delay, estimate_delays, identify_lifted,
    identify_lifted_iv, identify_multirate, identify_one_step_iv,
};
pub use lifting::{LiftedData, MultirateLifting, Ordering, SisoRates, Slot, lift, unlift};
pub use model::{
    ObservabilityReport, condition_one, lift_model, lift_single_rate, observability,
    siso_lifted_model,
};
pub use polyphase::{
    lifted_impulse, polyphase_components, polyphase_impulse, pseudo_circulant_impulse,
    recombine_lifted_impulse, recombine_lifted_tf, recombine_polyphase_impulse,
    recombine_polyphase_tf, substitute_power,
};
