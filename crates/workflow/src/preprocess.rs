//! Preprocessing: offsets removed from the records (the operating point
//! stored with the model), and a record less an operating point.

use lifted_lti::data::Detrend as LtiDetrend;
use lifted_lti::{Dataset, OperatingPoint};
use nalgebra::DMatrix;

use crate::error::{Context, Result};
use crate::options::Detrend;

/// The pooled per-channel means of the records (the operating point stored
/// with the model) and the records detrended per `detrend`.
pub fn detrend_sets(
    sets: Vec<Dataset>,
    detrend: Detrend,
) -> Result<(Option<OperatingPoint>, Vec<Dataset>)> {
    let kind = match detrend {
        Detrend::None => return Ok((None, sets)),
        Detrend::Mean => LtiDetrend::Constant,
        Detrend::Linear => LtiDetrend::Linear,
    };
    let us: Vec<&DMatrix<f64>> = sets.iter().map(Dataset::u).collect();
    let ys: Vec<&DMatrix<f64>> = sets.iter().map(Dataset::y).collect();
    let op = OperatingPoint::means(&us, &ys).ctx("detrend")?;
    let out = sets
        .iter()
        .map(|d| d.detrend(kind).ctx("detrend"))
        .collect::<Result<_>>()?;
    Ok((Some(op), out))
}

/// A record less an operating point (the data the model's deviations are
/// fitted to), or the record itself.
pub fn deviations(data: &Dataset, op: Option<&OperatingPoint>) -> Result<Dataset> {
    match op {
        Some(op) => {
            let neg = |v: &[f64]| v.iter().map(|x| -x).collect::<Vec<f64>>();
            data.shifted(&neg(&op.u0), &neg(&op.y0))
                .ctx("operating point")
        }
        None => Ok(data.clone()),
    }
}
