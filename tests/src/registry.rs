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

/// Every registered experiment, in spec order.
pub fn experiments() -> Vec<Experiment> {
    use crate::a3_lifting;
    vec![
        experiment!(
            "A2.2-A2.7",
            "a25-closedloop",
            "Ren & Zhu 2009: closed-loop set-ups, Tables 2-6, eqs. (16)-(17)",
            crate::a2_closedloop::run
        ),
        experiment!(
            "A3.2",
            "a32-lifting",
            "Lifting and Proposition 1: structural tests",
            a3_lifting::run_a32
        ),
        experiment!(
            "A3.3",
            "a33-observability",
            "§4.3 example: loss of observability (m=1, n=3)",
            a3_lifting::run_a33
        ),
        experiment!(
            "A3.4",
            "a34-delay",
            "§4.4 example: time-delay estimation (m=2, n=3, d_c=8.5)",
            a3_lifting::run_a34
        ),
        experiment!(
            "A3.5",
            "a35-extraction",
            "§4.5–4.6: causal lifted D and fast-model extraction",
            a3_lifting::run_a35
        ),
    ]
}

/// The experiments whose id or name equals `key` (case-insensitive).
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
    fn ids_and_names_are_unique() {
        let all = experiments();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(a.id, b.id);
                assert_ne!(a.name, b.name);
            }
        }
        assert_eq!(find("a33-observability").len(), 1);
        assert_eq!(find("A3.3").len(), 1);
        assert!(find("nope").is_empty());
    }
}
