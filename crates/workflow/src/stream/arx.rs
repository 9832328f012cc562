//! ARX and FIR of a given structure from a record read in blocks (a file
//! streamed, shards of one record; issue 49): one pass of the correlation
//! kernel into a compression plan's lag sums
//! (`lifted_subspace::CompressionPlan` / `PieceStream`), the record's Hankel
//! factor (centred by the channel means of all its samples), then the least
//! squares of `lifted_pem::arx_compressed` — the in-memory route's model
//! (`crate::routes::polynomial`: the record less its means, divided by the
//! channel scales of its first [`crate::SCALE_ROWS`] rows) up to the
//! rounding of the summation order, with memory O(k² + block) whatever N
//! (k = (L + 1)(n_u + n_y), L the longest lag) and one read of the file.
//!
//! Applies ([`applies`]) to `--method arx` with `--orders "na nb nk"` and
//! `--method fir` with `--orders "nb nk"`, least squares (no kernel), mean
//! or no detrending, inputs held one sample. Without a structure the scan
//! needs the record's held-out third (the record is loaded, as before);
//! when the correlations are too ill-conditioned for the Cholesky the
//! route gives way to the in-memory one, where the QR takes over.
//!
//! Cost: ≈ 2 N n_z² (L + 1) flops for the pass (the correlation kernel,
//! overlapping the reading when two or more threads are resolved), O(k³)
//! for the factor, O(n_y k d²) for the solves.

use lifted_lti::{ModelFile, OperatingPoint};
use lifted_pem::{ArxOptions, arx_compressed, arx_horizons};
use lifted_subspace::{CompressionPlan, PieceStream, SubspaceOptions};
use serde_json::json;

use super::{RecordSource, ScaledSource};
use crate::diagnostics::add_phase;
use crate::error::{Context, Error, Result};
use crate::options::{Detrend, Method, WorkflowOptions};
use crate::pipeline::Identified;
use crate::preprocess::ChannelScales;
use crate::validate::{finish_file, require_stable};

/// Whether the options take this route (module docs).
pub(crate) fn applies(opts: &WorkflowOptions) -> bool {
    let id = &opts.identification;
    matches!(id.method, Method::Arx | Method::Fir)
        && crate::routes::polynomial::fixed_structure(id).is_some()
        && id.kernel.is_none()
        && opts.data.detrend != Detrend::Linear
        && opts.data.hold <= 1
}

/// The route (module docs). `None` when the record turns out multirate
/// or its correlations too ill-conditioned: the caller loads it whole and
/// runs the in-memory workflow.
///
/// Errors: the reading's (a bad sample named with its place), the
/// structure's (orders that do not fit the channels, a record too short,
/// regressors that do not determine the parameters), a model that is not
/// stable when one is required.
pub(crate) fn identify(
    raw: &mut dyn RecordSource,
    opts: &WorkflowOptions,
) -> Result<Option<Identified>> {
    let id = &opts.identification;
    let Some(structure) = crate::routes::polynomial::fixed_structure(id) else {
        return Ok(None);
    };
    let threads = lifted_linalg::budget::resolve_threads(id.threads.unwrap_or(0));
    let mut source = ScaledSource {
        inner: raw,
        scales: None,
        ahead: threads > 1,
    };
    let (n_u, n_y) = source.channels();
    if n_u == 0 || n_y == 0 {
        return Ok(None); // the in-memory route reports the missing columns
    }
    let orders = crate::routes::polynomial::orders_of(id, structure, n_u, n_y);
    let (past, future) = arx_horizons(&orders);
    let remove_means = opts.data.detrend != Detrend::None;
    let plan_options = SubspaceOptions {
        past,
        future,
        remove_means,
        ..Default::default()
    };
    let what = format!("{} estimation", id.method.name().to_uppercase());
    let t_total = std::time::Instant::now();
    let mut stream: Option<PieceStream> = None;
    let pass = source.pass(&mut |u, y| {
        let s = match stream.as_mut() {
            Some(s) => s,
            None => {
                let plan = CompressionPlan::from_first_block(u, y, &plan_options).ctx(&what)?;
                stream.insert(plan.stream(threads))
            }
        };
        s.push(u, y).ctx(&what)
    })?;
    if pass.multirate {
        return Ok(None);
    }
    let stream = stream.ok_or_else(|| Error::Data("the record has no samples".into()))?;
    let records = stream.finish().ctx(&what)?.close().ctx(&what)?;
    let read_s = t_total.elapsed().as_secs_f64();
    let arx_opts = ArxOptions {
        threads,
        ..Default::default()
    };
    let fit = match arx_compressed(records, &orders, pass.ts, &arx_opts) {
        Ok(f) => f,
        Err(lifted_pem::Error::Subspace(lifted_subspace::Error::IllConditionedCorrelation {
            ..
        })) => return Ok(None),
        Err(e) => {
            return Err(Error::Step {
                what,
                source: Box::new(e),
            });
        }
    };
    // Back to the data's units (the blocks were divided by the channel
    // scales of the record's first rows, as the in-memory route's records).
    let sc = source.scales.clone().unwrap_or_else(|| ChannelScales {
        u: vec![1.0; n_u],
        y: vec![1.0; n_y],
    });
    let poly = crate::routes::polynomial::in_units(&sc, &fit.arx.model)?;
    let (model, kalman_gain) = poly
        .to_innovations_ss()
        .ctx("the polynomial model's state-space form")?;
    if opts.validation.require_stable {
        require_stable(&model)?;
    }
    let operating_point = remove_means.then(|| {
        sc.operating_point(&OperatingPoint {
            u0: fit.means[..n_u].to_vec(),
            y0: fit.means[n_u..].to_vec(),
        })
    });
    let mut d = crate::routes::polynomial::arx_diagnostics(
        id,
        structure,
        &fit.arx,
        serde_json::Value::Null,
        serde_json::Value::Null,
    );
    if let Some(obj) = d.as_object_mut() {
        obj.insert(
            "streamed".into(),
            json!("one pass over the record in blocks into the lagged correlations (memory independent of its length)"),
        );
    }
    let identify_s = t_total.elapsed().as_secs_f64() - read_s;
    add_phase(&mut d, "arx_s", identify_s);
    super::add_streamed_facts(
        &mut d,
        opts,
        (pass.rows, pass.ts, n_y),
        (read_s, identify_s),
    );
    let operating_point =
        crate::preprocess::stated_operating_point(operating_point, opts.data.detrend, &model)?;
    let file = ModelFile::with_polynomial(poly.clone())
        .ctx("the polynomial model file")?
        .with_method(id.method.name())
        .with_diagnostics(d);
    let file = finish_file(file, operating_point, Some(&kalman_gain))?;
    let order = file.model.order();
    Ok(Some(Identified {
        file,
        x0: Vec::new(),
        singular_values: Vec::new(),
        order,
        suggested_order: order,
        details: crate::RouteDetails {
            polynomial: Some(poly),
            ..Default::default()
        },
    }))
}
