//! What the studio keeps between two requests so that a move of the order
//! slider costs O(k³) and the (B, D, x₀) regression instead of a new read
//! of the CSV file and a new O(N) compression:
//!
//! * the parsed record ([`Loaded`]) of the current channel selection,
//!   keyed by the data specification (inputs, outputs, base period, hold,
//!   declared output periods);
//! * step 1 of the subspace identification
//!   ([`lifted_workflow::SubspaceCache`]), which the workflow layer reuses
//!   when the records and the compression options are those of the last run;
//! * the last [`KEPT_IDENTIFICATIONS`] model files, by their command line
//!   (every option and data file of `lifted identify`), and their
//!   validations, by that and the validation file: the identification is
//!   deterministic, so a slider moved back to an order, or a request that
//!   changes only the view, gets the model it got before without running
//!   the identification (its Kalman-gain check, the largest cost of a
//!   move at 1e5 samples) or the validation again. Forgotten with the
//!   record, and whenever the further experiments or the validation
//!   record change.
//!
//! # The same model as `lifted identify`
//!
//! The studio identifies with the command's own function,
//! [`identify_files_with`](crate::service::identify::identify_files_with),
//! with this cache as its [`RecordKeeper`]: the route, the options and the
//! model file are those of `lifted identify` with the page's command line,
//! and the kept compression gives the model bit for bit
//! (`lifted_workflow::identify_cached`). The page makes the horizon, the
//! (A, C) route and period 1 for every complete output explicit for a
//! numeric order (`Session::explicit`), so the command takes the in-memory
//! route, where the cache applies.

use lifted_lti::spectral::{FrequencyResponse, SpectralOptions, welch};
use lifted_lti::{Dataset, ModelFile};
use lifted_workflow::SubspaceCache;

use crate::error::{CliResult, input};
use crate::service::identify::RecordKeeper;
use crate::service::validation::Validation;
use crate::table::{DataSpec, Loaded, load};

/// The parsed record and the compressed data of the last requests.
#[derive(Default)]
pub struct Cache {
    /// The last [`KEPT_RECORDS`] parsed selections, most recent last.
    data: Vec<(String, Loaded)>,
    subspace: SubspaceCache,
    reads: usize,
    /// Welch's estimate of the last record's frequency response, with the
    /// key of the data it was made from.
    spectral: Option<(String, FrequencyResponse)>,
    /// The last identifications by their key (`Session`: the command
    /// line and the ranges), most recent last.
    models: Vec<(String, ModelFile)>,
    /// The last validations by their key (the identification's and the
    /// validation file's): the detrended model file, the record and the
    /// results.
    validations: Vec<(String, Validated)>,
    identifications: usize,
}

/// A model file validated on a record: the model as validated (detrended
/// like the record), the record and the results.
pub type Validated = (ModelFile, Dataset, Validation);

/// Identifications (and validations) kept: the slider's neighbourhood of
/// orders and a few method or horizon changes; each holds a model file
/// of a few kB, a validation the record's simulated outputs (O(N n_y)).
pub const KEPT_IDENTIFICATIONS: usize = 16;

/// Validations kept (each holds a copy of the validation record).
const KEPT_VALIDATIONS: usize = 4;

/// `value` of `key` moved to the end of `list` (most recent), if kept.
fn recent<T: Clone>(list: &mut Vec<(String, T)>, key: &str) -> Option<T> {
    let i = list.iter().position(|(k, _)| k == key)?;
    let kept = list.remove(i);
    let value = kept.1.clone();
    list.push(kept);
    Some(value)
}

/// `value` kept under `key` at the end of `list`, the oldest dropped
/// beyond `limit`.
fn keep<T>(list: &mut Vec<(String, T)>, key: String, value: T, limit: usize) {
    list.retain(|(k, _)| *k != key);
    if list.len() >= limit {
        list.remove(0);
    }
    list.push((key, value));
}

/// Parsed selections kept: the page's view (channels only) and its
/// identification (with the explicit output periods of
/// `Session::explicit`) read the same columns with two specifications, and
/// a validation record a third.
const KEPT_RECORDS: usize = 3;

/// The key of a data specification (its fields, exactly: a base period
/// is compared by its bits through `Debug`, which prints f64 exactly).
fn data_key(path: &str, spec: &DataSpec) -> String {
    format!(
        "{path}|{:?}|{:?}|{:?}|{:?}|{}|{:?}",
        spec.inputs, spec.outputs, spec.extra, spec.ts, spec.hold, spec.periods
    )
}

impl Cache {
    /// Forgets everything (a new record, a reset).
    pub fn clear(&mut self) {
        self.data.clear();
        self.subspace.clear();
        self.spectral = None;
        self.forget_identifications();
    }

    /// Forgets the kept identifications and validations (the further
    /// experiments or the validation record changed).
    pub fn forget_identifications(&mut self) {
        self.models.clear();
        self.validations.clear();
    }

    /// The model file identified before under `key`, if kept.
    pub fn identification(&mut self, key: &str) -> Option<ModelFile> {
        recent(&mut self.models, key)
    }

    /// Keeps the model file identified under `key`.
    pub fn keep_identification(&mut self, key: String, file: ModelFile) {
        self.identifications += 1;
        keep(&mut self.models, key, file, KEPT_IDENTIFICATIONS);
    }

    /// The validation made before under `key`, if kept.
    pub fn validation(&mut self, key: &str) -> Option<Validated> {
        recent(&mut self.validations, key)
    }

    /// Keeps the validation made under `key`.
    pub fn keep_validation(&mut self, key: String, validated: Validated) {
        keep(&mut self.validations, key, validated, KEPT_VALIDATIONS);
    }

    /// Identifications run (not taken from the kept ones) since the
    /// session began.
    pub fn identifications(&self) -> usize {
        self.identifications
    }

    /// Welch's estimate of the frequency response of `data` (default
    /// segments, [`lifted_lti::spectral::welch`]), made once per record
    /// and channel selection; `None` when the record is too short or the
    /// estimate fails (the Bode plot then shows the model alone).
    pub fn spectral(&mut self, data: &Dataset) -> Option<&FrequencyResponse> {
        // The selection and the record's size and sums identify the data
        // (a new record or selection clears or changes them).
        let sums: Vec<u64> = data
            .u()
            .column_iter()
            .chain(data.y().column_iter())
            .map(|c| c.iter().sum::<f64>().to_bits())
            .collect();
        let names: Vec<&str> = data
            .inputs()
            .iter()
            .map(|c| c.name.as_str())
            .chain(data.outputs().iter().map(|c| c.name.as_str()))
            .collect();
        let key = format!("{names:?}|{}|{}|{sums:?}", data.len(), data.ts());
        if self.spectral.as_ref().is_none_or(|(k, _)| *k != key) {
            self.spectral = None;
            let g = welch(data.u(), data.y(), data.ts(), &SpectralOptions::default()).ok()?;
            self.spectral = Some((key, g));
        }
        self.spectral.as_ref().map(|(_, g)| g)
    }

    /// The record `path` read with `spec` (read once per specification).
    pub fn loaded(&mut self, path: &str, spec: &DataSpec) -> CliResult<&Loaded> {
        let key = data_key(path, spec);
        match self.data.iter().position(|(k, _)| *k == key) {
            Some(i) => {
                let kept = self.data.remove(i);
                self.data.push(kept);
            }
            None => {
                let l = load(path, spec)?;
                self.reads += 1;
                if self.data.len() >= KEPT_RECORDS {
                    self.data.remove(0);
                }
                self.data.push((key, l));
            }
        }
        match self.data.last() {
            Some((_, l)) => Ok(l),
            None => Err(input("internal: the record was not kept")),
        }
    }

    /// Records read and compressions made since the session began (the
    /// tests check that a slider move makes neither).
    pub fn counts(&self) -> (usize, usize) {
        (self.reads, self.subspace.compressions())
    }
}

impl RecordKeeper for Cache {
    fn loaded(&mut self, path: &str, spec: &DataSpec) -> CliResult<Loaded> {
        Cache::loaded(self, path, spec).cloned()
    }

    fn subspace_cache(&mut self) -> Option<&mut SubspaceCache> {
        Some(&mut self.subspace)
    }
}
