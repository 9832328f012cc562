//! The streamed route: single-rate N4SID / MOESP / CVA of one record read
//! in blocks from a [`RecordSource`] (a file, shards of one record), in two
//! passes. The first pass pushes the blocks to
//! `lifted_subspace::StreamingIdentifier` (the Hankel compression, then
//! (A, C)); the second feeds the output-error (B, D, x₀) regression
//! (`StreamedSubspace::regression`), so the model is the one the in-memory
//! identification gives and memory is O(((m + l) s)² + block) whatever the
//! record length. The first pass keeps the blocks of a record of up to
//! [`KEEP_MAX_BYTES`] for the second instead of reading the source again.

use lifted_lti::{Dataset, ModelFile, StateSpace};
use lifted_subspace::{
    Compression, OrderSelection, StreamedSubspace, StreamingIdentifier, SubspaceModel,
    SubspaceOptions,
};
use nalgebra::DMatrix;
use serde_json::json;

use crate::diagnostics::{add_phase, add_run_facts, subspace_json};
use crate::error::{Context, Error, Result};
use crate::excitation::InputSpread;
use crate::gain::checked_gain;
use crate::options::{Detrend, OrderCriterion, Refine, WorkflowOptions};
use crate::pipeline::Identified;
use crate::preprocess::{ChannelScales, SCALE_ROWS, deviations};
use crate::refine::{
    HeldOutCheck, Refines, auto_allows, auto_decides, refine, refinement_cost, stabilized_start,
    work_of_size,
};
use crate::selection::{capped_to_supported, push_capped_search_warning};
use crate::subspace_options::{
    bd_of, criterion_of, method_of, order_of, subspace_options, system_of,
};
use crate::validate::{finish_file, require_stable};

mod arx;

/// What a pass over a record source saw.
#[derive(Debug, Clone, Copy)]
pub struct Pass {
    /// Rows delivered.
    pub rows: usize,
    /// Base period of the record.
    pub ts: f64,
    /// The record turned out multirate (an output not sampled at every
    /// instant): the pass stopped, the caller loads the record whole.
    pub multirate: bool,
}

/// What a pass delivers its blocks to: (u block, y block), rows of
/// samples, in record order.
pub type BlockSink<'a> = dyn FnMut(&DMatrix<f64>, &DMatrix<f64>) -> Result<()> + 'a;

/// A single record read in blocks, as often as the streamed route needs.
/// `Send`: a pass may run on a reading thread ahead of the arithmetic.
pub trait RecordSource: Send {
    /// Numbers of inputs and outputs of the record.
    fn channels(&self) -> (usize, usize);

    /// One pass over the record in order: blocks of rows, (u block,
    /// y block), to `push`; stops (and says so) at the first row with an
    /// output not sampled. Errors of `push` are returned as they are.
    fn pass(&mut self, push: &mut BlockSink<'_>) -> Result<Pass>;

    /// The whole record in memory (for the refinement).
    fn load(&mut self) -> Result<Dataset>;
}

/// Whether the options allow the streamed route at all: a single-rate
/// subspace method, an order rule that needs no simulation of candidates
/// on the records (not AIC-type), no trend removal, no input hold. The
/// caller adds what depends on its data (one record, no declared output
/// periods, no instruments, and not small enough for the held-out
/// selection when [`WorkflowOptions::wants_selection`]); or ARX / FIR of
/// a given structure, least squares (`crate::stream_arx`).
pub fn streamable(opts: &WorkflowOptions) -> bool {
    let id = &opts.identification;
    if arx::applies(opts) {
        return true;
    }
    id.method.is_subspace()
        && !matches!(
            id.order_criterion,
            OrderCriterion::Aic | OrderCriterion::Aicc | OrderCriterion::Bic
        )
        && opts.data.detrend != Detrend::Linear
        && opts.data.hold <= 1
}

/// Largest record (bytes of its input and output samples) the first pass of
/// a streamed identification keeps for the second, instead of reading the
/// source again: 64 MiB (1e6 samples of 2 inputs and 2 outputs take 32 MB),
/// so memory stays bounded whatever the record length.
pub const KEEP_MAX_BYTES: usize = 64 << 20;

/// The blocks of the first pass, while they fit in their limit (`None`
/// once they do not: the second pass reads the source again).
struct KeptBlocks {
    blocks: Option<Vec<(DMatrix<f64>, DMatrix<f64>)>>,
    bytes: usize,
    limit: usize,
}

impl KeptBlocks {
    fn with_limit(limit: usize) -> Self {
        KeptBlocks {
            blocks: Some(Vec::new()),
            bytes: 0,
            limit,
        }
    }

    fn keep(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) {
        let Some(blocks) = self.blocks.as_mut() else {
            return;
        };
        self.bytes += (u.len() + y.len()) * std::mem::size_of::<f64>();
        if self.bytes > self.limit {
            self.blocks = None;
        } else {
            blocks.push((u.clone(), y.clone()));
        }
    }
}

/// Runs the workflow on a record read in blocks from `source` (see the
/// module docs). The structure is the options' (horizon 10 unless given,
/// shift invariance unless given; an automatic order under
/// [`OrderCriterion::Validation`] by Bauer's SVC: the record is too large
/// for the held-out selection), its search bound capped, with the
/// in-memory route's warning, at the largest order the horizon identifies
/// ((f − 1) n_y: 9 for one output at horizon 10). An unstable model is
/// kept and warned about (another order would cost the passes again). If
/// the fast correlation compression is rejected as ill-conditioned, the
/// record is read again with the R-only QR compression (reported in the
/// diagnostics). The refinement then refines
/// this model on the record loaded in memory, so it starts from exactly
/// the model the plain identification gives.
///
/// Returns `None` when the options do not allow the route ([`streamable`])
/// or the record turns out multirate: the caller then loads it whole and
/// calls [`crate::identify`].
pub fn identify_streamed(
    raw: &mut dyn RecordSource,
    opts: &WorkflowOptions,
) -> Result<Option<Identified>> {
    opts.check()?;
    if arx::applies(opts) {
        return arx::identify(raw, opts);
    }
    if !streamable(opts) {
        return Ok(None);
    }
    // The machine's threads unless given (results depend on the count
    // through rounding only): with two or more, each pass reads on a
    // thread of its own ahead of the arithmetic (the compression's and
    // the regression's threads take their ranges in turn, so the reading
    // thread beside them holds none of them up).
    let threads = lifted_linalg::budget::resolve_threads(opts.identification.threads.unwrap_or(0));
    // The channels divided by their scales, as the in-memory routes take
    // them (preprocess::ChannelScales): the same model from both.
    let mut scaled = ScaledSource {
        inner: raw,
        scales: None,
        ahead: threads > 1,
    };
    let source = &mut scaled;
    let id = &opts.identification;
    let (n_u, n_y) = source.channels();
    if n_u == 0 || n_y == 0 {
        return Ok(None); // the in-memory route reports the missing columns
    }
    let what = format!("{} identification", method_of(id.method).name());
    // Too large a record for the held-out selection: horizon 10, shift
    // invariance, and Bauer's SVC for an automatic order.
    let criterion = match id.order_criterion {
        OrderCriterion::Validation => lifted_subspace::OrderCriterion::Svc,
        c => criterion_of(c),
    };
    let opts_with = |compression: Compression| SubspaceOptions {
        method: method_of(id.method),
        order: order_of(id),
        order_criterion: criterion,
        past: id.horizon.unwrap_or(10),
        future: id.horizon.unwrap_or(10),
        system: system_of(id.estimator),
        bd: bd_of(id.bd),
        remove_means: opts.data.detrend != Detrend::None,
        noise_model: id.noise_model,
        enforce_stability: stabilized_start(opts),
        feedthrough: crate::subspace_options::feedthrough_of(id, true),
        ts: 1.0,
        compression,
        // The machine's threads by default (results depend on the count
        // through rounding only): the correlation kernel and the second
        // pass's modal regression.
        threads: id.threads.unwrap_or(0),
        ..Default::default()
    };
    // An automatic order's search bound beyond what the horizon identifies
    // (10 by default, one output at horizon 10: orders up to 9) is capped
    // there with a warning, as in memory.
    let mut capped_search = None;
    let mut first_pass =
        |compression: Compression| -> Result<Option<(StreamedSubspace, Pass, KeptBlocks)>> {
            let (mut sid, _, capped) = capped_to_supported(opts_with(compression), |o| {
                StreamingIdentifier::new(n_u, n_y, o).ctx(&what)
            })?;
            capped_search = capped;
            let mut kept = KeptBlocks::with_limit(KEEP_MAX_BYTES);
            let pass = source.pass(&mut |u, y| {
                kept.keep(u, y);
                sid.push(u, y).ctx(&what)
            })?;
            if pass.multirate {
                return Ok(None);
            }
            // The integrator tolerance of the record (2/N by default), as
            // the in-memory route gives the identification: a marginal
            // estimate under --stable is moved just inside, not re-estimated
            // by the zero-padded shift.
            let longest = if pass.rows > 0 {
                pass.rows
            } else {
                sid.samples()
            };
            sid.set_marginal_tolerance(crate::integrators::tolerance_for(opts, longest).0)
                .ctx(&what)?;
            match sid.finish_subspace() {
                Ok(first) => Ok(Some((first, pass, kept))),
                Err(lifted_subspace::Error::IllConditionedCorrelation { .. })
                    if compression != Compression::Qr =>
                {
                    Ok(None)
                }
                Err(e) => Err(Error::Step {
                    what: what.clone(),
                    source: Box::new(e),
                }),
            }
        };
    let t_total = std::time::Instant::now();
    let first = first_pass(Compression::Auto).and_then(|r| match r {
        Some(r) => Ok(Some(r)),
        None => first_pass(Compression::Qr),
    });
    let (first, pass, kept) = match first {
        Ok(Some(r)) => r,
        Ok(None) => return Ok(None),
        // A refusal of the inputs: one more pass finds the inputs to name
        // (only then: the reading pass stays as lean as it was).
        Err(e) if crate::excitation::refuses_inputs(&e) => {
            let mut spread = InputSpread::new(n_u);
            source.inner.pass(&mut |u, _| {
                spread.push(u);
                Ok(())
            })?;
            return Err(crate::excitation::named(e, &spread));
        }
        // The memory budget refuses the horizons before the record's
        // length is known; a record too short for them anyway is the more
        // direct thing to say: one more pass counts its rows (only then).
        Err(e) if exceeds_budget(&e) => {
            let (p, f) = (id.horizon.unwrap_or(10), id.horizon.unwrap_or(10));
            let mut rows = 0usize;
            source.inner.pass(&mut |u, _| {
                rows += u.nrows();
                Ok(())
            })?;
            let min_samples = (p + f).saturating_mul(n_u + n_y).saturating_add(p + f - 1);
            if rows < min_samples {
                return Err(Error::Step {
                    what,
                    source: Box::new(lifted_subspace::Error::HorizonTooLong {
                        past: p,
                        future: f,
                        n_samples: rows,
                        min_samples,
                    }),
                });
            }
            return Err(e);
        }
        Err(e) => return Err(e),
    };
    let read_s = t_total.elapsed().as_secs_f64();
    let t_second = std::time::Instant::now();
    let second = first.wants_second_pass();
    let fit = if second {
        second_pass(source, first, kept, &what)?
    } else {
        first.into_model()
    };
    let second_pass_s = t_second.elapsed().as_secs_f64();
    let (ts, n_rows) = (pass.ts, pass.rows);
    // The default feedthrough as in memory (crate::routes::feedthrough): on a
    // record that is loaded anyway (the gain check's size), D free against
    // the D = 0 model identified on it at the same structure; longer
    // records keep D (the test would need more passes over the file).
    let mut early = None;
    let mut zero_chosen = false;
    let (fit, feedthrough) = match crate::routes::feedthrough::settled(id, &fit) {
        Some(said) => (fit, said),
        None if n_rows <= opts.budgets.gain_check_samples => {
            let record = source.load()?;
            // The in-memory route's options at the order found, so that
            // both routes compare the same D = 0 model.
            let zero_opts = SubspaceOptions {
                order: lifted_subspace::OrderSelection::Fixed(fit.diagnostics.order),
                feedthrough: lifted_subspace::Feedthrough::Zero,
                past: fit.diagnostics.horizons.0,
                future: fit.diagnostics.horizons.1,
                system: system_of(id.estimator),
                // The record's integrator tolerance, as the first pass had.
                marginal_tolerance: crate::integrators::tolerance_for(opts, record.len()).0,
                ..crate::subspace_options::subspace_options(
                    opts,
                    record.ts(),
                    opts.data.detrend != Detrend::None,
                )
            };
            let exps = [lifted_subspace::Experiment {
                u: record.u(),
                y: record.y(),
            }];
            let zero = lifted_subspace::identify(&exps, &zero_opts).ctx(&what);
            let (fit, zero_kept, said) =
                crate::routes::feedthrough::choose(fit, zero, std::slice::from_ref(&record));
            zero_chosen = zero_kept;
            early = Some(record);
            (fit, said)
        }
        None => (
            fit,
            json!(format!(
                "D estimated (the streamed route's default for records over {} samples: the in-memory route's test of D against D = 0 would need more passes over the file; --feedthrough false fixes D = 0)",
                opts.budgets.gain_check_samples
            )),
        ),
    };
    let m = &fit.model;
    let model = StateSpace::new(
        m.a().clone(),
        m.b().clone(),
        m.c().clone(),
        m.d().clone(),
        Some(ts),
    )
    .ctx("identify")?;
    let mut d = subspace_json(
        &fit,
        "single-rate subspace identification, streamed in blocks",
    );
    if let Some(obj) = d.as_object_mut() {
        obj.insert("feedthrough".into(), feedthrough);
    }
    if let Some(cap) = capped_search {
        push_capped_search_warning(&mut d, cap);
    }
    if second {
        add_phase(&mut d, "second_pass_s", second_pass_s);
    }
    let mut kalman_gain = fit.kalman_gain.clone();
    // The default refinement decides from the record's size before the
    // record is loaded for it (and the refinement below then runs as
    // decided, `Refine::Pem`).
    let decided = auto_decides(opts, &d);
    // (The first pass was given the record's integrator tolerance once it
    // had read the record; the refinement below uses it too.)
    let marginal = crate::integrators::tolerance_for(opts, n_rows).0;
    // (Not capped: a record over the budget is not loaded for it.)
    let allowed = auto_allows(
        opts,
        &model,
        &mut d,
        n_rows,
        marginal,
        |p| work_of_size(&model, n_rows, p),
        false,
    );
    let refines = refinement_cost(opts, &d).is_some() && allowed != Refines::No;
    // The record in memory (and its deviations from the model's operating
    // point) when the gain is checked on it or the model refined on it.
    let loaded = if refines || n_rows <= opts.budgets.gain_check_samples {
        let record = match early.take() {
            Some(r) => r,
            None => source.load()?,
        };
        let set = deviations(&record, fit.operating_point.as_ref())?;
        Some((record, set))
    } else {
        None
    };
    if let Some((record, set)) = &loaded {
        // As the in-memory route: the same gain from the same record.
        let raw = opts.data.detrend != Detrend::None;
        kalman_gain = checked_gain(
            &model,
            kalman_gain,
            std::slice::from_ref(set),
            raw.then_some(std::slice::from_ref(record)),
            &mut d,
            crate::gain::GainCheckWith {
                past: fit.diagnostics.horizons.0,
                options: &opts.identification.gain_check,
                most_samples: opts.budgets.gain_check_samples,
                memo: None,
                records_hash: None,
            },
        );
    }
    let t_refine = std::time::Instant::now();
    let (model, mut d) = match loaded {
        Some((record, set)) if refines => {
            // The refinement starts from the model above, on the record in
            // memory (deviations from the model's operating point).
            let mut run = opts.clone();
            if decided {
                run.refinement.refine = Refine::Pem;
            }
            // A short record (structure given, so streamed) is judged as the
            // in-memory route judges it: on held-out blocks of the record as
            // the identification took it.
            let base = subspace_options(opts, record.ts(), opts.data.detrend != Detrend::None);
            let check_opts = SubspaceOptions {
                order: OrderSelection::Fixed(fit.diagnostics.order),
                past: fit.diagnostics.horizons.0,
                future: fit.diagnostics.horizons.1,
                feedthrough: if zero_chosen {
                    lifted_subspace::Feedthrough::Zero
                } else {
                    base.feedthrough.clone()
                },
                ..base
            };
            let check = (record.len() <= opts.budgets.refine_check_samples).then(|| HeldOutCheck {
                sets: std::slice::from_ref(&record),
                options: &check_opts,
                known: None,
            });
            let (model, mut d) = refine(&run, model, d, &[set], &mut kalman_gain, check)?;
            add_phase(&mut d, "refine_s", t_refine.elapsed().as_secs_f64());
            (model, d)
        }
        other => {
            // No refinement: `refine` only records a stable
            // identification's route, and under --stable moves a marginal
            // model's poles just inside and polishes it on the record when
            // it is loaded (as in memory).
            let mut none = opts.clone();
            none.refinement.refine = Refine::None;
            // The record's integrator tolerance (the record may not be
            // passed): `--stable` moves marginal poles just inside by it.
            none.identification.integrator_tolerance =
                Some(crate::integrators::tolerance_for(opts, n_rows).0);
            let sets: Vec<Dataset> = other.map(|(_, set)| vec![set]).unwrap_or_default();
            refine(&none, model, d, &sets, &mut kalman_gain, None)?
        }
    };
    crate::integrators::report(opts, n_rows, &model, &mut d);
    // Back to the data's units.
    let sc = source.scales.clone().unwrap_or_else(|| ChannelScales {
        u: vec![1.0; n_u],
        y: vec![1.0; n_y],
    });
    let model = sc.model(&model)?;
    let kalman_gain = kalman_gain.map(|k| sc.gain(&k));
    let operating_point = fit
        .operating_point
        .as_ref()
        .map(|op| sc.operating_point(op));
    if opts.validation.require_stable {
        require_stable(&model)?;
    }
    // Reading and compressing overlap: blocks are compressed as they are
    // read; the identification's time is everything after the first pass.
    let identify_s = t_total.elapsed().as_secs_f64() - read_s;
    add_streamed_facts(&mut d, opts, (n_rows, ts, n_y), (read_s, identify_s));
    let dg = &fit.diagnostics;
    let operating_point =
        crate::preprocess::stated_operating_point(operating_point, opts.data.detrend, &model)?;
    let file = finish_file(
        ModelFile::new(model)
            .with_method(id.method.name())
            .with_diagnostics(d),
        operating_point,
        kalman_gain.as_ref(),
    )?;
    Ok(Some(Identified {
        file,
        x0: fit.x0.clone(),
        singular_values: dg.singular_values.clone(),
        order: dg.order,
        suggested_order: dg.suggested_order,
        details: crate::RouteDetails::default(),
    }))
}

/// The run facts, selection policy and resolved plan of a streamed run of
/// `rows` samples at period `ts` with `n_y` outputs (every output at the
/// base rate), read in `read_s` and identified in `identify_s`.
fn add_streamed_facts(
    d: &mut serde_json::Value,
    opts: &WorkflowOptions,
    (rows, ts, n_y): (usize, f64, usize),
    (read_s, identify_s): (f64, f64),
) {
    add_run_facts(d, rows, ts, &vec![1; n_y], Some(read_s), identify_s);
    crate::diagnostics::add_selection_policy(d, opts);
    if let Some(obj) = d.as_object_mut() {
        let shape = crate::plan::DataShape {
            records: 1,
            samples: rows,
            longest: rows,
            multirate: false,
            streamed: true,
        };
        obj.insert(
            "plan".into(),
            serde_json::to_value(crate::plan::resolved_defaults(opts, &shape)).unwrap_or_default(),
        );
    }
}

/// A record source whose channels are divided by the channel scales
/// ([`ChannelScales::of`]: the first [`SCALE_ROWS`] rows). The first pass
/// holds its blocks back until it has seen those rows (or the record's
/// end), then delivers them and the rest scaled; later passes and
/// [`RecordSource::load`] use the same scales.
///
/// With `ahead`, a pass reads, checks and scales on a thread of its own,
/// up to [`READ_AHEAD`] blocks ahead of the arithmetic that takes them
/// (the same blocks in the same order: the same model), so that reading
/// overlaps the compression and the regression instead of leaving the
/// other core idle.
pub(crate) struct ScaledSource<'s> {
    pub(crate) inner: &'s mut dyn RecordSource,
    pub(crate) scales: Option<ChannelScales>,
    pub(crate) ahead: bool,
}

/// What [`ScaledSource::scaled_pass`] delivers to: a raw block (u, y) and
/// the channel scales to apply to it.
type ScaledSink<'a> = dyn FnMut(&DMatrix<f64>, &DMatrix<f64>, &ChannelScales) -> Result<()> + 'a;

/// Blocks a reading thread may hold ready beyond the one being taken:
/// two keep the arithmetic fed through an uneven read, and bound the
/// memory to a few blocks.
const READ_AHEAD: usize = 2;

impl ScaledSource<'_> {
    /// The scales of the first [`SCALE_ROWS`] rows of `held`.
    fn scales_of(held: &[(DMatrix<f64>, DMatrix<f64>)], n_u: usize, n_y: usize) -> ChannelScales {
        let rows = held
            .iter()
            .map(|(u, _)| u.nrows())
            .sum::<usize>()
            .min(SCALE_ROWS);
        let (mut u, mut y) = (DMatrix::zeros(rows, n_u), DMatrix::zeros(rows, n_y));
        let mut at = 0;
        for (bu, by) in held {
            let take = bu.nrows().min(rows - at);
            u.rows_mut(at, take).copy_from(&bu.rows(0, take));
            y.rows_mut(at, take).copy_from(&by.rows(0, take));
            at += take;
            if at == rows {
                break;
            }
        }
        ChannelScales::of_rows(&u, &y)
    }
}

impl ScaledSource<'_> {
    /// One pass with the reading on a thread of its own: its blocks,
    /// scaled into buffers that come back once taken, through a channel of
    /// [`READ_AHEAD`] to `push` on the calling thread. An error of `push`
    /// stops the reading (the channel closes) and is returned.
    fn pass_ahead(&mut self, push: &mut BlockSink<'_>) -> Result<Pass> {
        type Block = (DMatrix<f64>, DMatrix<f64>);
        let (full_tx, full_rx) = std::sync::mpsc::sync_channel::<Block>(READ_AHEAD);
        let (free_tx, free_rx) = std::sync::mpsc::channel::<Block>();
        let stopped = || Error::Source("the reading stopped: the blocks were refused".into());
        std::thread::scope(|scope| {
            let reader = scope.spawn(move || {
                self.scaled_pass(&mut |u, y, sc| {
                    let (mut bu, mut by) = free_rx
                        .try_recv()
                        .unwrap_or_else(|_| (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0)));
                    sc.apply_block_into(u, y, &mut bu, &mut by);
                    full_tx.send((bu, by)).map_err(|_| stopped())
                })
            });
            let mut pushed = Ok(());
            while let Ok((u, y)) = full_rx.recv() {
                pushed = push(&u, &y);
                if pushed.is_err() {
                    break;
                }
                // The reader may have finished: its buffers are not needed.
                let _ = free_tx.send((u, y));
            }
            drop(full_rx);
            let read = reader
                .join()
                .unwrap_or_else(|_| Err(Error::Source("the reading thread failed".into())));
            pushed?;
            read
        })
    }

    /// One pass on the calling thread: every block of the source with the
    /// channel scales to `deliver` (which scales it where it wants it),
    /// the first blocks held back until the scales are known
    /// ([`SCALE_ROWS`] rows, or the record's end).
    fn scaled_pass(&mut self, deliver: &mut ScaledSink<'_>) -> Result<Pass> {
        let (n_u, n_y) = self.inner.channels();
        let mut held: Vec<(DMatrix<f64>, DMatrix<f64>)> = Vec::new();
        let mut rows = 0;
        let scales = &mut self.scales;
        let pass = self.inner.pass(&mut |u, y| {
            if let Some(sc) = scales.as_ref() {
                return deliver(u, y, sc);
            }
            held.push((u.clone(), y.clone()));
            rows += u.nrows();
            if rows >= SCALE_ROWS {
                let sc = Self::scales_of(&held, n_u, n_y);
                for (u, y) in held.drain(..) {
                    deliver(&u, &y, &sc)?;
                }
                *scales = Some(sc);
            }
            Ok(())
        })?;
        if !held.is_empty() && !pass.multirate {
            // A record shorter than SCALE_ROWS: its scales, then its blocks.
            let sc = Self::scales_of(&held, n_u, n_y);
            for (u, y) in held.drain(..) {
                deliver(&u, &y, &sc)?;
            }
            self.scales = Some(sc);
        }
        Ok(pass)
    }
}

impl RecordSource for ScaledSource<'_> {
    fn channels(&self) -> (usize, usize) {
        self.inner.channels()
    }

    fn pass(&mut self, push: &mut BlockSink<'_>) -> Result<Pass> {
        if self.ahead {
            return self.pass_ahead(push);
        }
        // The scaled blocks, reused from block to block.
        let (mut su, mut sy) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0));
        self.scaled_pass(&mut |u, y, sc| {
            sc.apply_block_into(u, y, &mut su, &mut sy);
            push(&su, &sy)
        })
    }

    fn load(&mut self) -> Result<Dataset> {
        let d = self.inner.load()?;
        let sc = match &self.scales {
            Some(sc) => sc.clone(),
            None => ChannelScales::of(std::slice::from_ref(&d)),
        };
        let out = sc.apply(&d)?;
        self.scales = Some(sc);
        Ok(out)
    }
}

/// The second pass of the streamed identification: the record read again
/// (or the kept blocks) into the output-error (B, D, x₀) regression for the
/// first pass's (A, C). A regression that cannot run (A too unstable for
/// the record, regressors rank deficient) keeps the one-pass model and says
/// so in its fallbacks.
fn second_pass(
    source: &mut dyn RecordSource,
    first: StreamedSubspace,
    kept: KeptBlocks,
    what: &str,
) -> Result<SubspaceModel> {
    let mut bd = match first.regression() {
        Ok(bd) => bd,
        Err(e) => return Ok(with_fallback(first.into_model(), &e)),
    };
    match kept.blocks {
        // The first pass kept the (small) record: no second read.
        Some(blocks) => {
            for (u, y) in &blocks {
                bd.push(u, y).ctx(what)?;
            }
        }
        None => {
            source.pass(&mut |u, y| bd.push(u, y).ctx(what))?;
        }
    }
    first.finish(bd).map_err(|e| Error::Step {
        what: what.to_string(),
        source: Box::new(e),
    })
}

/// The one-pass model with a note of why the output-error (B, D) was not
/// used.
fn with_fallback(mut fit: SubspaceModel, e: &lifted_subspace::Error) -> SubspaceModel {
    fit.diagnostics.fallbacks.push(format!(
        "(B, D) from the projection on the compressed data: the output-error regression was refused ({e})"
    ));
    fit
}

/// Whether `e` is a subspace identification's refusal by the memory budget.
fn exceeds_budget(e: &Error) -> bool {
    let Error::Step { source, .. } = e else {
        return false;
    };
    source
        .downcast_ref::<lifted_subspace::Error>()
        .is_some_and(lifted_subspace::Error::exceeds_memory_budget)
}

#[cfg(test)]
mod kept_tests {
    use super::*;

    #[test]
    fn the_first_pass_keeps_blocks_up_to_its_limit_only() {
        let (u, y) = (DMatrix::zeros(10, 2), DMatrix::zeros(10, 2));
        // 320 bytes per block.
        let mut k = KeptBlocks::with_limit(700);
        k.keep(&u, &y);
        k.keep(&u, &y);
        assert_eq!(k.blocks.as_ref().map(Vec::len), Some(2));
        k.keep(&u, &y);
        assert!(
            k.blocks.is_none(),
            "over the limit: the sources are read again"
        );
        k.keep(&u, &y);
        assert!(k.blocks.is_none());
    }
}
