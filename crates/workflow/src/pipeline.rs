//! The pipeline on records in memory: preprocessing → identification (the
//! route the method and the data call for) → refinement → validation.

use lifted_lti::{Dataset, ModelFile, OperatingPoint};
use nalgebra::{DMatrix, DVector};

use crate::cache::SubspaceCache;
use crate::diagnostics::{add_phase, add_run_facts};
use crate::error::{Context, Error, Result};
use crate::excitation::InputSpread;
use crate::gain::{GainCheckWith, checked_gain};
use crate::options::{Detrend, Method, Refine, WorkflowOptions};
use crate::preprocess::{ChannelScales, detrended, deviations};
use crate::refine::{HeldOutCheck, refine};
use crate::routes::multirate_start;
use crate::routes::{self, RouteDetails, RouteFit};
use crate::validate::{finish_file, require_stable};

/// One record (experiment) in memory, with its instrument columns for the
/// IV method.
#[derive(Debug, Clone)]
pub struct Record {
    /// The data set (inputs, outputs, base period, output sampling).
    pub data: Dataset,
    /// The instrument columns, N × n_u (IV only; `None`: the inputs).
    pub instrument: Option<DMatrix<f64>>,
}

impl Record {
    /// A record without instrument.
    pub fn new(data: Dataset) -> Self {
        Record {
            data,
            instrument: None,
        }
    }
}

/// What a workflow run gives: the model file (model, operating point,
/// Kalman gain, diagnostics) and what the front ends show besides.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The model file: the model (deviations from the operating point), the
    /// operating point, the Kalman gain and the diagnostics JSON (route,
    /// order selection, structure selection, refinement, stability,
    /// warnings, profile).
    pub file: ModelFile,
    /// The identification's initial state per record (of the deviation
    /// record; before any refinement). Empty on the routes without it
    /// (multirate, q-Markov, a streamed record).
    pub x0: Vec<DVector<f64>>,
    /// The values the order was chosen from (singular values, or the Λ
    /// diagonal of the q-Markov Cover).
    pub singular_values: Vec<f64>,
    /// The identification's order.
    pub order: usize,
    /// The order the singular values suggest.
    pub suggested_order: usize,
    /// What the route gives besides (the lifted model of a multirate
    /// route, the Markov parameters of the q-Markov Cover); empty on the
    /// other routes and on a streamed record.
    pub details: RouteDetails,
}

/// Names of the instrument columns written to the IV diagnostics (empty:
/// the inputs). A front end that reads named columns passes them with
/// [`identify_named`].
const NO_NAMES: &[String] = &[];

/// Runs the workflow on records in memory: [`identify_named`] without
/// instrument names.
pub fn identify(records: &[Record], opts: &WorkflowOptions) -> Result<Identified> {
    identify_named(records, opts, NO_NAMES)
}

/// Runs the workflow on records in memory: the preprocessing
/// (`opts.data.detrend`; single-rate N4SID/MOESP/CVA remove the means
/// inside the identification), the identification route of
/// `opts.identification.method` (multirate records take the lifted routes),
/// the refinement (`opts.refinement`, on the detrended records), and the
/// validation (stability in the diagnostics, `opts.validation`).
/// `instrument_names`: the IV instrument columns' names for the
/// diagnostics.
///
/// Errors: [`Error::InvalidOption`] naming an option that is invalid or
/// does not apply to the records, [`Error::Data`], [`Error::Step`] with the
/// failing step's error.
pub fn identify_named(
    records: &[Record],
    opts: &WorkflowOptions,
    instrument_names: &[String],
) -> Result<Identified> {
    run_named(records, opts, instrument_names, None)
}

/// [`identify_named`] with step 1 of the single-rate subspace route kept in
/// `cache` between calls ([`SubspaceCache`]): the same model bit for bit,
/// without a new compression when the records and the compression options
/// are those of the previous call (a new order, method or (B, D) route).
///
/// Errors: those of [`identify_named`].
pub fn identify_cached(
    records: &[Record],
    opts: &WorkflowOptions,
    instrument_names: &[String],
    cache: &mut SubspaceCache,
) -> Result<Identified> {
    run_named(records, opts, instrument_names, Some(cache))
}

/// The outputs (0-based) whose every measured value over the records is
/// the same, with that value. O(N n_y).
fn constant_outputs(records: &[Record]) -> Vec<(usize, f64)> {
    let n_y = records.first().map_or(0, |r| r.data.y().ncols());
    let mut out = Vec::new();
    'outputs: for j in 0..n_y {
        let mut first = None;
        for r in records {
            for &v in r.data.y().column(j).iter().filter(|v| v.is_finite()) {
                match first {
                    None => first = Some(v),
                    Some(f) if f != v => continue 'outputs,
                    Some(_) => {}
                }
            }
        }
        if let Some(f) = first {
            out.push((j, f));
        }
    }
    out
}

/// [`run`], its refusal of non-exciting inputs naming the constant or tied ones
/// ([`crate::excitation`]).
fn run_named(
    records: &[Record],
    opts: &WorkflowOptions,
    instrument_names: &[String],
    cache: Option<&mut SubspaceCache>,
) -> Result<Identified> {
    run(records, opts, instrument_names, cache, None).map_err(|e| {
        if !crate::excitation::refuses_inputs(&e) {
            return e;
        }
        let n_u = records.first().map_or(0, |r| r.data.n_inputs());
        let spread = InputSpread::of(n_u, records.iter().map(|r| r.data.u()));
        crate::excitation::named(e, &spread)
    })
}

/// One run inside the multirate route's held-out check
/// (`crate::routes::multirate_check`): the workflow on `sets` without that
/// check (the route's own choices made as in any run, but the start the
/// whole record's run kept, `held`, when given).
fn identify_fold(
    sets: &[Dataset],
    opts: &WorkflowOptions,
    held: Option<multirate_start::Start>,
) -> Result<Identified> {
    let records: Vec<Record> = sets.iter().cloned().map(Record::new).collect();
    run(&records, opts, NO_NAMES, None, Some(Fold { held }))
}

/// A run inside the multirate held-out check: it does not check itself
/// again, and takes the multirate start `held` without comparing the two.
#[derive(Debug, Clone, Copy)]
struct Fold {
    held: Option<multirate_start::Start>,
}

/// The workflow; `fold`: a run inside the multirate held-out check.
fn run(
    records: &[Record],
    opts: &WorkflowOptions,
    instrument_names: &[String],
    mut cache: Option<&mut SubspaceCache>,
    fold: Option<Fold>,
) -> Result<Identified> {
    opts.check()?;
    let id = &opts.identification;
    if records.is_empty() {
        return Err(Error::Data("no data record".into()));
    }
    let with_instruments = records.iter().any(|r| r.instrument.is_some());
    if with_instruments && id.method != Method::Iv {
        return Err(Error::option("instrument", "only used with the iv method"));
    }
    let t_identify = std::time::Instant::now();
    let multirate = records.iter().any(|r| !r.data.is_single_rate());
    // What the defaults left to the run will decide on these records, said
    // before the heavy work (diagnostics.plan).
    let plan = opts.plan(&crate::plan::DataShape {
        records: records.len(),
        samples: records.iter().map(|r| r.data.len()).sum(),
        longest: records.iter().map(|r| r.data.len()).max().unwrap_or(0),
        multirate,
        streamed: false,
    })?;
    let subspace_single_rate = !multirate && id.method.is_subspace();
    // Single-rate N4SID/MOESP/CVA remove the means inside the
    // identification (as the streamed route does: the output-error
    // regression then also estimates the constant a response that started
    // at rest keeps); the other routes take the detrended records.
    let inner_means = subspace_single_rate && opts.data.detrend == Detrend::Mean;
    // (One copy of the records: the detrended sets, or the records as they
    // are; the scaling below divides that copy in place.)
    let (mut operating_point, mut sets): (Option<OperatingPoint>, Vec<Dataset>) = if inner_means {
        (None, records.iter().map(|r| r.data.clone()).collect())
    } else {
        let refs: Vec<&Dataset> = records.iter().map(|r| &r.data).collect();
        detrended(&refs, opts.data.detrend)?
    };
    // Every route but the q-Markov Cover (whose PRBS amplitudes are in the
    // data's units) identifies on channels of unit standard deviation, so
    // that the model does not depend on the units
    // (preprocess::ChannelScales).
    let scales = (id.method != Method::Qmarkov).then(|| ChannelScales::of(&sets));
    if let Some(sc) = &scales {
        sets = sets
            .into_iter()
            .map(|d| sc.apply_owned(d))
            .collect::<Result<_>>()?;
    }
    let ts = sets[0].ts();
    // The records and options of a single-rate subspace identification, for
    // the held-out check of its refinement.
    type Check = (
        Vec<Dataset>,
        lifted_subspace::SubspaceOptions,
        Option<lifted_pem::RefinementCheck>,
    );
    let mut check: Option<Check> = None;
    let mut alternative: Option<std::result::Result<lifted_lti::StateSpace, String>> = None;
    let mut refined_by_route = false;
    // The multirate subspace route with its second start also compares the
    // interpolated start as identified (multirate_start::or_as_identified).
    let mut third_start = false;
    // The hash of the records identified (single-rate subspace route with a
    // cache): computed once, for every cache of the run.
    let mut records_hash: Option<u64> = None;
    let fit: RouteFit = match id.method {
        Method::Qmarkov => routes::qmarkov(opts, &sets)?,
        m if m.is_subspace() && multirate => {
            // A second start, the interpolated record's single-rate model
            // (crate::routes::multirate_start), when it applies; it identifies the
            // record alone when the lifted route fails.
            let second = multirate_start::applies(opts, &sets);
            third_start = second;
            let t_route = std::time::Instant::now();
            match routes::multirate(opts, &sets) {
                Ok((fit, made)) => {
                    let mut fit = fit;
                    // The lifted route's wall time: lifting, its order
                    // selection (held-out fits, the refined shortlist)
                    // and the fast model's extraction.
                    add_phase(
                        &mut fit.diagnostics,
                        "multirate_s",
                        t_route.elapsed().as_secs_f64(),
                    );
                    // (A route that already took the interpolated start,
                    // its lifted identification having failed, has no
                    // second start to compare; one that made the start
                    // already hands it over.)
                    if second && fit.diagnostics.get("multirate_start").is_none() {
                        let t = std::time::Instant::now();
                        alternative = Some(match made {
                            Some(m) => Ok(m),
                            None => multirate_start::start(opts, &sets, Some(fit.model.order()))
                                .map(|(m, _)| m)
                                .map_err(|e| e.to_string()),
                        });
                        add_phase(
                            &mut fit.diagnostics,
                            "multirate_start_s",
                            t.elapsed().as_secs_f64(),
                        );
                    }
                    fit
                }
                // An option the multirate route refuses stays an error.
                Err(e) if second && !matches!(e, Error::InvalidOption { .. }) => {
                    multirate_start::instead_of_lifted(opts, &sets, &e, None).map_err(|_| e)?
                }
                Err(e) => return Err(e),
            }
        }
        m if m.is_subspace() => {
            let t_subspace = std::time::Instant::now();
            let routes::SubspaceRoute {
                fit,
                diagnostics: d,
                used,
                check: known,
                records_hash: hash,
            } = routes::subspace(opts, &sets, inner_means, cache.as_deref_mut())?;
            records_hash = hash;
            let route_sets = if inner_means {
                // The refinement and the stored model see deviations from
                // the identification's operating point.
                let dev = sets
                    .iter()
                    .map(|r| deviations(r, fit.operating_point.as_ref()))
                    .collect::<Result<_>>()?;
                operating_point = fit.operating_point.clone();
                std::mem::replace(&mut sets, dev)
            } else if sets.iter().map(Dataset::len).sum::<usize>()
                <= opts.budgets.refine_check_samples
            {
                sets.clone()
            } else {
                Vec::new()
            };
            // The subspace step's Kalman gain checked on the records
            // (lifted_subspace::check_kalman_gain): the gain that predicts
            // best is kept.
            let mut d = d;
            add_phase(&mut d, "subspace_s", t_subspace.elapsed().as_secs_f64());
            let kalman_gain = checked_gain(
                &fit.model,
                fit.kalman_gain,
                &sets,
                inner_means.then_some(route_sets.as_slice()),
                &mut d,
                GainCheckWith {
                    past: used.past,
                    options: &opts.identification.gain_check,
                    most_samples: opts.budgets.gain_check_samples,
                    memo: cache.as_deref_mut().map(|c| &mut c.gain),
                    records_hash,
                },
            );
            if !route_sets.is_empty() {
                check = Some((route_sets, used, known));
            }
            let dg = &fit.diagnostics;
            RouteFit {
                singular_values: dg.singular_values.clone(),
                order: dg.order,
                suggested_order: dg.suggested_order,
                details: routes::RouteDetails::default(),
                kalman_gain,
                x0: fit.x0,
                model: fit.model,
                diagnostics: d,
            }
        }
        // Multirate records under feedback without an instrument: the
        // direct prediction-error method, refined within the route
        // (crate::routes::multirate_predictor).
        Method::Pbsid | Method::Ssarx | Method::PbsidRowwise if multirate => {
            refined_by_route = true;
            crate::routes::multirate_predictor::identify(opts, &sets)?
        }
        Method::Pbsid | Method::Ssarx | Method::PbsidRowwise => {
            routes::pbsid(id, &sets, multirate)?
        }
        // Process models (crate::routes::process), final as estimated.
        Method::Process => {
            refined_by_route = true;
            crate::routes::process::identify(opts, &sets, scales.as_ref())?
        }
        // ARX, FIR: the least-squares polynomial model, final as estimated
        // (crate::routes::polynomial).
        m if m.is_polynomial() => {
            refined_by_route = true;
            crate::routes::polynomial::identify(opts, &sets, multirate)?
        }
        _ => {
            let instruments: Vec<Option<&DMatrix<f64>>> =
                records.iter().map(|r| r.instrument.as_ref()).collect();
            let mut fit = routes::iv(opts, &sets, &instruments, instrument_names, multirate)?;
            if !multirate {
                // The IV route gives no noise model: the gain of the
                // regression on VARX innovations or K = 0, refined over K
                // on the records (its VARX order α), so that its model
                // predicts as the subspace routes' do.
                let alpha = fit.diagnostics["horizons"][0].as_u64().unwrap_or(8) as usize;
                fit.kalman_gain = checked_gain(
                    &fit.model,
                    None,
                    &sets,
                    None,
                    &mut fit.diagnostics,
                    GainCheckWith {
                        past: alpha,
                        options: &opts.identification.gain_check,
                        most_samples: opts.budgets.gain_check_samples,
                        memo: None,
                        records_hash: None,
                    },
                );
            }
            fit
        }
    };
    let RouteFit {
        model,
        diagnostics,
        mut kalman_gain,
        x0,
        singular_values,
        order,
        suggested_order,
        mut details,
    } = fit;
    // The records before the identification removed its operating point
    // (the same for every order of a record): the feedback test's
    // model-free innovations are estimated on them.
    let before: Option<&[Dataset]> = check.as_ref().map(|(sets, _, _)| sets.as_slice());
    let check = check.as_ref().map(|(sets, options, known)| HeldOutCheck {
        sets,
        options,
        known: known.as_ref(),
    });
    let t_refine = std::time::Instant::now();
    let (model, diagnostics) = match alternative {
        _ if refined_by_route => (model, diagnostics),
        Some(Ok(alt)) => {
            let held = fold.and_then(|f| f.held);
            multirate_start::choose(opts, model, diagnostics, &sets, &mut kalman_gain, alt, held)?
        }
        Some(Err(why)) => {
            let (model, mut d) = refine(opts, model, diagnostics, &sets, &mut kalman_gain, check)?;
            if let Some(obj) = d.as_object_mut() {
                obj.insert(
                    "multirate_start".into(),
                    serde_json::json!({
                        "kept": multirate_start::START_LIFTED,
                        "note": format!("no interpolated start: {why}"),
                    }),
                );
            }
            (model, d)
        }
        None => refine(opts, model, diagnostics, &sets, &mut kalman_gain, check)?,
    };
    // The held-out check's time (its own phase, not the refinement's).
    let mut checking = 0.0;
    let (model, mut diagnostics) = if third_start {
        let chosen =
            multirate_start::or_as_identified(opts, (model, diagnostics), &sets, &mut kalman_gain);
        if fold.is_some() {
            chosen
        } else {
            let t = std::time::Instant::now();
            let run = |sets: &[Dataset], o: &WorkflowOptions, held| {
                identify_fold(sets, o, held)
                    .ok()
                    .map(|r| ((r.file.model, r.file.operating_point), r.file.diagnostics))
            };
            let (model, mut d, shift) = crate::routes::multirate_check::against_interpolation(
                opts,
                chosen,
                &sets,
                &mut kalman_gain,
                &run,
            );
            // The interpolated record's model deviates from that record's
            // means (in the units of `sets`): its operating point is the
            // run's plus those.
            if let Some(shift) = shift {
                let shift = match &scales {
                    Some(sc) => sc.operating_point(&shift),
                    None => shift,
                };
                operating_point = Some(match operating_point.take() {
                    Some(op) => OperatingPoint {
                        u0: op.u0.iter().zip(&shift.u0).map(|(a, b)| a + b).collect(),
                        y0: op.y0.iter().zip(&shift.y0).map(|(a, b)| a + b).collect(),
                    },
                    None => shift,
                });
            }
            checking = t.elapsed().as_secs_f64();
            add_phase(&mut d, "multirate_check_s", checking);
            (model, d)
        }
    } else {
        (model, diagnostics)
    };
    let longest = sets.iter().map(Dataset::len).max().unwrap_or(0);
    crate::integrators::report(opts, longest, &model, &mut diagnostics);
    if opts.refinement.refine != Refine::None {
        add_phase(
            &mut diagnostics,
            "refine_s",
            t_refine.elapsed().as_secs_f64() - checking,
        );
    }
    // A multirate model that the refinement did not give a Kalman gain
    // (not refined, or not by the prediction error): the gain checked on
    // the measured samples from K = 0 (lifted_subspace::check_kalman_gain;
    // the lifted routes estimate none).
    if multirate
        && kalman_gain.is_none()
        && model
            .ts()
            .zip(sets.first())
            .is_some_and(|(t, d)| (t - d.ts()).abs() <= 1e-9 * d.ts())
    {
        kalman_gain = checked_gain(
            &model,
            None,
            &sets,
            None,
            &mut diagnostics,
            GainCheckWith {
                past: 0,
                options: &opts.identification.gain_check,
                most_samples: opts.budgets.gain_check_samples,
                memo: None,
                records_hash: None,
            },
        );
    }
    crate::feedback::report(
        opts,
        &model,
        kalman_gain.as_ref(),
        &sets,
        before.map(|b| (b, records_hash)),
        cache.map(|c| &mut c.feedback),
        &mut diagnostics,
    );
    // The covariance of a state-space model's entries (crate::covariance),
    // on the records it was identified on; polynomial and process models
    // carry their own.
    let covariance = if details.polynomial.is_some() {
        None
    } else if opts.validation.covariance {
        crate::covariance::of_model(opts, &model, kalman_gain.as_ref(), &sets, &mut diagnostics)
    } else {
        crate::covariance::not_asked(&mut diagnostics);
        None
    };
    let covariance = match (&scales, covariance) {
        (Some(sc), Some(c)) => Some(sc.ss_covariance(&c, &model)?),
        (_, c) => c,
    };
    // Back to the data's units (an operating point from the detrending is
    // in them already; one from inside the identification is not).
    let model = match &scales {
        Some(sc) => {
            kalman_gain = kalman_gain.map(|k| sc.gain(&k));
            if inner_means {
                operating_point = operating_point.map(|op| sc.operating_point(&op));
            }
            if let (Some(lifted), Some((ins, outs))) = (&details.lifted, &details.lifted_channels) {
                details.lifted = Some(sc.lifted_model(lifted, ins, outs)?);
            }
            sc.model(&model)?
        }
        None => model,
    };
    // A polynomial model in the data's units; the model and its gain are
    // its innovations realisation.
    let polynomial = match details.polynomial.take() {
        Some(p) => {
            let p = match &scales {
                Some(sc) => crate::routes::polynomial::in_units(sc, &p)?,
                None => p,
            };
            details.polynomial = Some(p.clone());
            Some(p)
        }
        None => None,
    };
    let model = match &polynomial {
        Some(p) => {
            let (m, k) = p
                .to_innovations_ss()
                .ctx("the polynomial model's state-space form")?;
            kalman_gain = Some(k);
            m
        }
        None => model,
    };
    if opts.validation.require_stable {
        require_stable(&model)?;
    }
    let identify_s = t_identify.elapsed().as_secs_f64();
    let periods: Vec<usize> = sets[0].outputs().iter().map(|c| c.period).collect();
    let samples = sets.iter().map(Dataset::len).sum::<usize>();
    crate::diagnostics::criterion_from_selection(&mut diagnostics);
    add_run_facts(&mut diagnostics, samples, ts, &periods, None, identify_s);
    crate::diagnostics::add_selection_policy(&mut diagnostics, opts);
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "plan".into(),
            serde_json::to_value(&plan).unwrap_or_default(),
        );
    }
    for (j, v) in constant_outputs(records) {
        crate::diagnostics::push_warning(
            &mut diagnostics,
            format!(
                "output {} is constant over the records (always {v}): there is nothing to identify for it (its fit is not defined and its noise model is singular, so no prediction fits); remove it from the outputs",
                j + 1
            ),
        );
    }
    let operating_point =
        crate::preprocess::stated_operating_point(operating_point, opts.data.detrend, &model)?;
    let file = match (polynomial, covariance) {
        (Some(p), _) => ModelFile::with_polynomial(p).ctx("the polynomial model file")?,
        (None, Some(c)) => ModelFile::new(model)
            .with_covariance(c)
            .ctx("the model's covariance")?,
        (None, None) => ModelFile::new(model),
    };
    let file = finish_file(
        file.with_method(id.method.name())
            .with_diagnostics(diagnostics),
        operating_point,
        kalman_gain.as_ref(),
    )?;
    Ok(Identified {
        file,
        x0,
        singular_values,
        order,
        suggested_order,
        details,
    })
}
