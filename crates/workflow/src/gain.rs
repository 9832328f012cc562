//! The Kalman-gain check of a subspace model on its records (the stage
//! after the subspace step, shared by the in-memory, streamed and multirate
//! predictor routes): `lifted_subspace::check_kalman_gain` within the
//! work budget, its report in `diagnostics.kalman_gain_route`.

use lifted_lti::Dataset;
use nalgebra::DMatrix;

use crate::diagnostics::add_phase;

/// How [`checked_gain`] checks a gain.
pub(crate) struct GainCheckWith<'a> {
    /// The VARX order of the innovation estimate (the identification's
    /// past horizon).
    pub past: usize,
    /// When the iterations over K stop.
    pub options: &'a lifted_subspace::GainCheckOptions,
    /// Records of more samples are checked on their last this many
    /// ([`crate::Budgets::gain_check_samples`], [`crate::window`]).
    pub most_samples: usize,
    /// The innovations kept between calls (a front end's
    /// [`SubspaceCache`]): the same gain bit for bit as without it.
    pub memo: Option<&'a mut lifted_subspace::VarxMemo>,
    /// The hash of the records before the identification removed its
    /// operating point (`raw` of [`checked_gain`]), when the run computed
    /// it ([`SubspaceCache::hash`]).
    pub records_hash: Option<u64>,
}

/// The Kalman gain of a single-rate subspace model on `sets` (deviations
/// from its operating point, as the identification took them): checked on
/// the records (`lifted_subspace::check_kalman_gain`, the report in
/// `diagnostics.kalman_gain_route`), on their last
/// [`crate::Budgets::gain_check_samples`] samples when they hold more
/// ([`crate::window`]: the check's cost stays at that record length's;
/// `diagnostics.kalman_gain_window` says so). The
/// in-memory and the streamed route both call it. `raw`: the records
/// before the identification removed its operating point, when it did:
/// the VARX innovations are estimated from them, each centred by its own
/// means (`lifted_subspace::VarxMemo::set_source`), the same for every
/// order of a record; `check`: the VARX order, the options and the memo
/// of the check ([`GainCheckWith`]).
pub(crate) fn checked_gain(
    model: &lifted_lti::StateSpace,
    gain: Option<DMatrix<f64>>,
    sets: &[Dataset],
    raw: Option<&[Dataset]>,
    diagnostics: &mut serde_json::Value,
    check: GainCheckWith<'_>,
) -> Option<DMatrix<f64>> {
    let GainCheckWith {
        past,
        options,
        most_samples,
        memo,
        records_hash,
    } = check;
    let samples: usize = sets.iter().map(Dataset::len).sum();
    if sets.is_empty() || most_samples == 0 {
        return gain;
    }
    // Longer records: the check on their last `most_samples` samples
    // (crate::window), the innovations of the same window; not memoised
    // (the memo is keyed by the whole records).
    let windows = if samples > most_samples {
        let last = crate::window::last_samples(sets, most_samples);
        let raw_last = raw
            .map(|r| crate::window::last_samples(r, most_samples))
            .transpose();
        match (last, raw_last) {
            (Ok(last), Ok(raw_last)) => Some((last, raw_last)),
            _ => return gain,
        }
    } else {
        None
    };
    let (sets, raw, memo, records_hash) = match &windows {
        Some((last, raw_last)) => (last.as_slice(), raw_last.as_deref(), None, None),
        None => (sets, raw, memo, records_hash),
    };
    let exps: Vec<lifted_subspace::Experiment<'_>> = sets
        .iter()
        .map(|r| lifted_subspace::Experiment { u: r.u(), y: r.y() })
        .collect();
    let t = std::time::Instant::now();
    let mut local = lifted_subspace::VarxMemo::default();
    let memo = memo.unwrap_or(&mut local);
    let raw_exps: Option<Vec<lifted_subspace::Experiment<'_>>> = raw.map(|r| {
        r.iter()
            .map(|d| lifted_subspace::Experiment { u: d.u(), y: d.y() })
            .collect()
    });
    match (raw_exps.as_deref(), records_hash) {
        (Some(r), Some(h)) => memo.set_source_hashed(Some((r, h))),
        (r, _) => memo.set_source(r),
    }
    let (checked, report) =
        lifted_subspace::check_kalman_gain_memo(model, gain.as_ref(), &exps, past, options, memo);
    add_phase(diagnostics, "kalman_gain_s", t.elapsed().as_secs_f64());
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "kalman_gain_route".into(),
            serde_json::to_value(&report).unwrap_or_default(),
        );
        if windows.is_some() {
            obj.insert(
                "kalman_gain_window".into(),
                serde_json::json!({
                    "samples": most_samples,
                    "of": samples,
                    "rule": "the gain checked on the records' last budgets.gain_check_samples samples",
                }),
            );
        }
    }
    checked
}
