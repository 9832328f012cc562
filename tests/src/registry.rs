//! The list of reproductions, shared by `lifted reproduce` and anything else
//! that wants to run them all.
//!
//! Each experiment is defined once, in its module; this file only names it.
//! Adding one is a one-line change to [`experiments`]:
//!
//! ```text
//! experiment!("A1.5", "a15-engine", "Zhu 2000 Tables II/III: diesel engine", a1_engine::run),
//! ```
//!
//! The run function may return `Box<dyn Error>` (not `Send`/`Sync`): the
//! macro converts its error into [`RunError`].

use crate::report::Reproduction;

/// The error of a run, as a message (thread-safe).
pub type RunError = Box<dyn std::error::Error + Send + Sync>;

/// One registered experiment.
#[derive(Debug, Clone, Copy)]
pub struct Experiment {
    /// Spec section, e.g. "A3.2" (the id of the report rows).
    pub id: &'static str,
    /// Short name for `--only`, e.g. "a32-lifting".
    pub name: &'static str,
    /// Title shown in the report.
    pub title: &'static str,
    /// Runs the experiment.
    pub run: fn() -> Result<Reproduction, RunError>,
}

/// Converts any displayable error into a [`RunError`] (keeps the message).
pub fn run_error(e: impl std::fmt::Display) -> RunError {
    e.to_string().into()
}

/// `experiment!(id, name, title, path::to::run)`: one registry entry; the
/// run function takes no argument and returns `Result<Reproduction, E>`
/// with `E: Display`.
#[macro_export]
macro_rules! experiment {
    ($id:expr, $name:expr, $title:expr, $run:path) => {
        $crate::registry::Experiment {
            id: $id,
            name: $name,
            title: $title,
            run: || $run().map_err($crate::registry::run_error),
        }
    };
}

/// Every registered experiment, in spec order (one line each).
#[rustfmt::skip]
pub fn experiments() -> Vec<Experiment> {
    use crate::{
        a1_engine, a1_prbs, a2_closedloop, a2_openloop, a3_delay_example, a3_dual_rate, a3_lifting, a3_mimo,
        a3_iv, a3_mpc, a3_multirate_iv, a3_polynomial, a3_subspace,
    };
    vec![
        experiment!("A1.1", "a11-taps", "Zhu 2000 Table I: m-sequence taps", a1_prbs::run_a11),
        experiment!("A1.2", "a12-inverse-prbs", "Zhu 2000 eqs. II-4–II-6: inverse PRBS", a1_prbs::run_a12),
        experiment!("A1.3", "a13-held-prbs", "Zhu 2000 eqs. II-7–II-10, Fig. 1: held PRBS autocorrelation", a1_prbs::run_a13),
        experiment!("A1.4", "a14-qmarkov", "Zhu 2000 eqs. III-22–III-30: weighted multirate q-Markov Cover", a1_prbs::run_a14),
        experiment!("A1.5", "a15-engine", "Zhu 2000 Tables II/III: diesel-engine stand-in, weighted multirate q-Markov Cover", a1_engine::run),
        experiment!("A2.1", "a21-prbs", "Ren & Zhu 2009 Table 1, eqs. 1–8: PRBS", a1_prbs::run_a21),
        experiment!("A2.2-A2.7", "a2-closedloop", "Ren & Zhu 2009: closed-loop set-ups, Tables 2-6, eqs. (16)-(17)", a2_closedloop::run),
        experiment!("A2.4", "a24-openloop", "Ren & Zhu 2009 eq. (14): open-loop q-Markov identification of G1 and G2", a2_openloop::run),
        experiment!("A3.1", "a31-subspace", "Li 2001 §2.6.2: CVA / N4SID / MOESP on the stirred tank", a3_subspace::run),
        experiment!("A3.2", "a32-lifting", "Lifting and Proposition 1: structural tests", a3_lifting::run_a32),
        experiment!("A3.3", "a33-observability", "§4.3 example: loss of observability (m=1, n=3)", a3_lifting::run_a33),
        experiment!("A3.4", "a34-delay", "§4.4 example: time-delay estimation (m=2, n=3, d_c=8.5)", a3_lifting::run_a34),
        experiment!("A3.5", "a35-extraction", "§4.5–4.6: causal lifted D and fast-model extraction", a3_lifting::run_a35),
        experiment!("A3.6", "a36-delay-example", "§4.8 example: delay, shift, lifted N4SID, matrix root", a3_delay_example::run),
        experiment!("A3.7", "a37-mimo", "§5.3.1: MIMO multirate (y1 every 5, y2 every 1)", a3_mimo::run_531),
        experiment!("A3.7b", "a37b-mimo-validation", "§5.3.2 stand-in: validation on fast-sampled data", a3_mimo::run_532),
        experiment!("A3.8a", "a38a-polyphase", "Ch. 6 polyphase identities and lifted ARX", a3_polynomial::run_polyphase),
        experiment!("A3.8b", "a38b-vectorized", "§6.3 vectorized excitation", a3_polynomial::run_vectorized),
        experiment!("A3.8c", "a38c-ccr", "§6.4 CCR stand-in: CCA input screening", a3_polynomial::run_ccr),
        experiment!("A3.9", "a39-iv", "§7.8.2 SISO: closed-loop IV subspace with past dither as instrument", a3_iv::run),
        experiment!("A3.9", "a39-iv-bias", "§7.8.2 SISO, var-SNR 0.5: closed-loop bias of plain N4SID against the IV method", a3_iv::run_bias),
        experiment!("A3.9b", "a39b-multirate-iv", "§7.8.2 multirate stirred tank: two-step lifted IV", a3_multirate_iv::run),
        experiment!("A3.10", "a310-mpc", "Li 2001 Ch. 8: DMC / GPC and dual-rate inferential MPC", a3_mpc::run),
        experiment!("A3.10", "a310-tank", "Stirred tank stand-in: inferential MPC, level every 10 T", a3_mpc::run_tank),
        experiment!("A3.11", "a311-dual-rate", "Li 2001 Ch. 9: dual-rate inferential control, §9.6 example", a3_dual_rate::run),
        experiment!("A3.11", "a311-random", "Cor. 1 on random triples; Prop. 5 lifted identities", a3_dual_rate::run_random),
    ]
}

/// The experiments whose id or name equals `key` (case-insensitive); an id
/// can name several experiments of one spec section.
pub fn find(key: &str) -> Vec<Experiment> {
    experiments()
        .into_iter()
        .filter(|e| e.id.eq_ignore_ascii_case(key) || e.name.eq_ignore_ascii_case(key))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_found() {
        let all = experiments();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(a.name, b.name);
            }
        }
        assert_eq!(find("a33-observability").len(), 1);
        assert_eq!(find("A3.3").len(), 1);
        assert!(find("nope").is_empty());
    }
}
