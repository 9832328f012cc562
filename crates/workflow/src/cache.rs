//! Step 1 of a subspace identification kept between runs on the same
//! records, for front ends that refit one record many times (the studio's
//! order slider): [`identify_cached`] equals [`crate::identify_named`]
//! exactly, but a single-rate N4SID/MOESP/CVA run without the held-out
//! structure selection takes its compressed data
//! ([`lifted_subspace::CompressedData`]: means removed, scaled,
//! block-Hankel factor, O(N (n_u + n_y)² s)) from the cache when the records
//! and what the compression depends on (horizon, mean removal, compression
//! kind, block size, threads) are those of the previous run, so a new order
//! costs O(k³) and the (B, D, x₀) regression instead of O(N) work more.
//! `CompressedData::identify` is how `lifted_subspace::identify` itself
//! runs, so the cached model is bit for bit the uncached one. The Kalman-gain
//! check's VARX innovations (`lifted_subspace::VarxMemo`, O(N (p n_z +
//! n_u)²), the check's largest cost) are kept too, per record as the
//! check sees it (the deviations from each model's operating point): an
//! order identified again reuses them, with the same gain bit for bit.
//! The feedback test on a single-rate record (its VARX innovations and the
//! Granger test on them, model-free: the same for every order) is kept
//! too, by the record and the test's options: a new order takes it.

use lifted_subspace::{CompressedData, Experiment, SubspaceModel, SubspaceOptions};

use crate::error::{Context, Result};

/// The compressed data of the last run, reused by [`crate::identify_cached`] when the records
/// and the compression options (horizon, mean removal, compression kind, block size,
/// threads) are those of that run: a new order then costs O(k³) and the (B, D, x₀)
/// regression, and gives the uncached model bit for bit.
#[derive(Default)]
pub struct SubspaceCache {
    kept: Option<(String, CompressedData<'static>)>,
    compressions: usize,
    /// The Kalman-gain check's VARX innovations of the last records
    /// ([`lifted_subspace::VarxMemo`]): an order checked again reuses them.
    pub(crate) gain: lifted_subspace::VarxMemo,
    /// The feedback test of the last single-rate record
    /// (`crate::feedback::FeedbackMemo`): every order takes it.
    pub(crate) feedback: crate::feedback::FeedbackMemo,
}

impl std::fmt::Debug for SubspaceCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SubspaceCache")
            .field("kept", &self.kept.as_ref().map(|(k, _)| k))
            .field("compressions", &self.compressions)
            .field("varx_estimates", &self.gain.computed())
            .field("feedback_tests", &self.feedback.computed())
            .finish()
    }
}

impl SubspaceCache {
    /// Compressions made since the cache was created (a refit of a kept
    /// compression makes none).
    pub fn compressions(&self) -> usize {
        self.compressions
    }

    /// VARX innovation estimates the Kalman-gain checks made through the
    /// cache (an order identified again on the same records makes none).
    pub fn varx_estimates(&self) -> usize {
        self.gain.computed()
    }

    /// Feedback tests on a VARX's errors made through the cache (a new
    /// order on a record already tested makes none).
    pub fn feedback_tests(&self) -> usize {
        self.feedback.computed()
    }

    /// Forgets the kept compression, innovations and feedback test.
    pub fn clear(&mut self) {
        self.kept = None;
        self.gain = lifted_subspace::VarxMemo::default();
        self.feedback = crate::feedback::FeedbackMemo::default();
    }

    /// `lifted_subspace::identify(exps, sub)`, from the kept compression
    /// when it was made from the same records with the same compression
    /// options. `hash`: the records' `lifted_subspace::records_hash`
    /// ([`SubspaceCache::hash`]).
    pub(crate) fn identify(
        &mut self,
        exps: &[Experiment<'_>],
        hash: u64,
        sub: &SubspaceOptions,
        what: &str,
    ) -> Result<SubspaceModel> {
        self.compressed(exps, hash, sub, what)?
            .identify(sub)
            .ctx(what)
    }

    /// The kept compression of `exps` with the compression options of
    /// `sub`, made (and kept) when it is not the one kept.
    fn compressed(
        &mut self,
        exps: &[Experiment<'_>],
        hash: u64,
        sub: &SubspaceOptions,
        what: &str,
    ) -> Result<&CompressedData<'static>> {
        let key = key_of(hash, sub);
        if self.kept.as_ref().is_none_or(|(k, _)| *k != key) {
            self.kept = None;
            let c = CompressedData::new(exps, sub).ctx(what)?.into_owned();
            self.compressions += 1;
            self.kept = Some((key, c));
        }
        match &self.kept {
            Some((_, c)) => Ok(c),
            None => Err(crate::error::Error::Data(
                "internal: the compression was not kept".into(),
            )),
        }
    }

    /// [`SubspaceCache::identify`] with `first` and `second`, two options
    /// of the same compression (the feedthrough test's D free and D = 0 at
    /// one structure), the second fit on a second thread while the first
    /// runs here: the fits of two calls, bit for bit. `None` when the two
    /// options do not share the compression.
    pub(crate) fn identify_pair(
        &mut self,
        exps: &[Experiment<'_>],
        hash: u64,
        (first, second): (&SubspaceOptions, &SubspaceOptions),
        what: &str,
    ) -> Option<(Result<SubspaceModel>, Result<SubspaceModel>)> {
        if key_of(hash, first) != key_of(hash, second) {
            return None;
        }
        let c = match self.compressed(exps, hash, first, what) {
            Ok(c) => c,
            Err(e) => {
                let again = e.to_string();
                return Some((Err(e), Err(crate::error::Error::Data(again))));
            }
        };
        Some(std::thread::scope(|scope| {
            let other = scope.spawn(|| c.identify(second).ctx(what));
            let a = c.identify(first).ctx(what);
            let b = other
                .join()
                .unwrap_or_else(|_| c.identify(second).ctx(what));
            (a, b)
        }))
    }
}

impl SubspaceCache {
    /// The records' `lifted_subspace::records_hash` (their sizes and the
    /// bits of every sample, O(N)): what tells records apart for the kept
    /// compression, innovations and feedback test. A run computes it once
    /// and hands it to each of them.
    pub(crate) fn hash(exps: &[Experiment<'_>]) -> u64 {
        lifted_subspace::records_hash(exps)
    }
}

/// What the compression depends on: the records (`hash`, their
/// [`SubspaceCache::hash`]) and the compression options.
fn key_of(hash: u64, sub: &SubspaceOptions) -> String {
    format!(
        "{:016x}|{}|{}|{}|{:?}|{}|{}",
        hash, sub.past, sub.future, sub.remove_means, sub.compression, sub.chunk_rows, sub.threads
    )
}
