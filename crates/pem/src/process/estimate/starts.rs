//! The starts of `procest`: a grid over the shape (time constants, ζ) and
//! the dead time with the gains solved by least squares at every point, and
//! Smith's two-point method on a step test.

use super::*;

/// A start on the grid: one input's physical block, the offset, the cost.
#[derive(Debug, Clone)]
struct Candidate {
    block: Vec<f64>,
    offset: f64,
    cost: f64,
    /// Grid coordinates (time-constant indices, shift) for distinctness.
    cell: (usize, usize, usize),
}

/// Basis responses of one grid shape (θ = 0, K = 1) per record, and how
/// the fitted coefficients map to (K, T_z).
fn shape_bases(
    kind: ProcessKind,
    shape: &[f64],
    (ts, hold): (f64, InterSample),
    inputs: &[&[f64]],
) -> Result<Vec<Vec<Vec<f64>>>> {
    let unit = |k: ProcessKind, p: &[f64]| {
        ProcessModel::from_parameters(k, p, ts).map(|m| m.with_intersample(hold))
    };
    let models = match kind {
        ProcessKind::P1D => vec![unit(kind, &[1.0, shape[0], 0.0])?],
        ProcessKind::P1DI => vec![unit(kind, &[1.0, shape[0], 0.0])?],
        ProcessKind::P2D => vec![unit(kind, &[1.0, shape[0], shape[1], 0.0])?],
        // y = K(1 − T_z/T₂) x₂ + K (T_z/T₂) x₁: bases x₂ (T_z = 0) and x₁ (T_z = T₂)
        ProcessKind::P2DZ => vec![
            unit(kind, &[1.0, shape[0], shape[1], 0.0, 0.0])?,
            unit(kind, &[1.0, shape[0], shape[1], shape[1], 0.0])?,
        ],
        ProcessKind::P2DU => vec![unit(kind, &[1.0, shape[0], shape[1], 0.0])?],
    };
    models
        .iter()
        .map(|m| {
            let d = Discrete::new(m)?;
            Ok(inputs
                .iter()
                .map(|u| {
                    let mut out = vec![0.0; u.len()];
                    d.add_response(u, 1.0, &mut out);
                    out
                })
                .collect())
        })
        .collect()
}

/// The grid search of input `j` against `target` (per record, NaN = not
/// measured): every shape, every coarse shift, gains (and offset) by least
/// squares; the best shift of each shape refined at single-sample
/// resolution. Candidates sorted by cost.
fn grid(p: &Problem<'_>, j: usize, target: &[Vec<f64>]) -> Result<Vec<Candidate>> {
    let lo = (p.ts / 2.0).ln();
    let hi = (p.duration / 4.0).max(p.ts).ln();
    let tcs: Vec<f64> = (0..GRID_TIME_CONSTANTS)
        .map(|i| (lo + (hi - lo) * i as f64 / (GRID_TIME_CONSTANTS - 1) as f64).exp())
        .collect();
    let mut shapes: Vec<(Vec<f64>, (usize, usize))> = Vec::new();
    match p.kind {
        ProcessKind::P1D | ProcessKind::P1DI => {
            for (a, &t) in tcs.iter().enumerate() {
                shapes.push((vec![t], (a, 0)));
            }
        }
        ProcessKind::P2D | ProcessKind::P2DZ => {
            for (a, &t1) in tcs.iter().enumerate() {
                for (b, &t2) in tcs.iter().enumerate().take(a + 1) {
                    shapes.push((vec![t1, t2], (a, b)));
                }
            }
        }
        ProcessKind::P2DU => {
            for (a, &t) in tcs.iter().enumerate() {
                for (b, &z) in GRID_ZETAS.iter().enumerate() {
                    shapes.push((vec![t, z], (a, b)));
                }
            }
        }
    }
    let d_max = (p.theta_max / p.ts).floor() as usize;
    let stride = (d_max + 1).div_ceil(GRID_SHIFTS).max(1);
    let inputs: Vec<&[f64]> = p.inputs.iter().map(|us| us[j].as_slice()).collect();
    let mut out = Vec::new();
    for (shape, cell) in shapes {
        let bases = shape_bases(p.kind, &shape, (p.ts, p.intersample), &inputs)?;
        let mut best: Option<(f64, usize, Vec<f64>)> = None;
        let consider = |d: usize, best: &mut Option<(f64, usize, Vec<f64>)>| {
            if let Some((c, coef)) = shifted_ls(&bases, target, d, p.offset)
                && best.as_ref().is_none_or(|b| c < b.0)
            {
                *best = Some((c, d, coef));
            }
        };
        for d in (0..=d_max).step_by(stride) {
            consider(d, &mut best);
        }
        if stride > 1
            && let Some((_, d0, _)) = best.clone()
        {
            for d in d0.saturating_sub(stride - 1)..=(d0 + stride - 1).min(d_max) {
                consider(d, &mut best);
            }
        }
        let Some((cost, d, coef)) = best else {
            continue;
        };
        let theta = d as f64 * p.ts;
        let (k, tz) = if p.kind == ProcessKind::P2DZ {
            let k = coef[0] + coef[1];
            let tz = if k.abs() > 1e-12 * (coef[0].abs() + coef[1].abs()) {
                shape[1] * coef[1] / k
            } else {
                0.0
            };
            (k, tz)
        } else {
            (coef[0], 0.0)
        };
        if !k.is_finite() || k == 0.0 {
            continue;
        }
        let block = match p.kind {
            ProcessKind::P2DZ => vec![k, shape[0], shape[1], tz, theta],
            _ => {
                let mut b = vec![k];
                b.extend_from_slice(&shape);
                b.push(theta);
                b
            }
        };
        let offset = if p.offset { coef[coef.len() - 1] } else { 0.0 };
        out.push(Candidate {
            block,
            offset,
            cost,
            cell: (cell.0, cell.1, d),
        });
    }
    out.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    Ok(out)
}

/// Least squares of the measured target on the bases delayed by `d`
/// samples (and a constant with `offset`): (residual sum of squares,
/// coefficients), None when singular.
fn shifted_ls(
    bases: &[Vec<Vec<f64>>],
    target: &[Vec<f64>],
    d: usize,
    offset: bool,
) -> Option<(f64, Vec<f64>)> {
    let nb = bases.len() + usize::from(offset);
    let mut g = DMatrix::<f64>::zeros(nb, nb);
    let mut h = DVector::<f64>::zeros(nb);
    let mut yy = 0.0;
    let mut x = vec![0.0; nb];
    for (e, y) in target.iter().enumerate() {
        for (t, &yt) in y.iter().enumerate() {
            if yt.is_nan() {
                continue;
            }
            for (b, basis) in bases.iter().enumerate() {
                x[b] = if t >= d { basis[e][t - d] } else { 0.0 };
            }
            if offset {
                x[nb - 1] = 1.0;
            }
            for a in 0..nb {
                h[a] += x[a] * yt;
                for b in 0..=a {
                    g[(a, b)] += x[a] * x[b];
                }
            }
            yy += yt * yt;
        }
    }
    for a in 0..nb {
        for b in 0..a {
            g[(b, a)] = g[(a, b)];
        }
    }
    let diag = (0..nb).map(|a| g[(a, a)]).fold(0.0, f64::max);
    if (0..nb).any(|a| g[(a, a)] <= 1e-12 * diag) {
        return None;
    }
    let c = g.clone().cholesky()?.solve(&h);
    let rss = (yy - h.dot(&c)).max(0.0);
    Some((rss, c.iter().copied().collect()))
}

/// Smith's two-point start on a single-input step test (the input takes two
/// values and changes once in the first record that does so): K from the
/// final value, T = 1.5 (t₆₃ − t₂₈), θ = t₆₃ − T; for P1DI the slope and
/// intercept of the response's last third. None when no record is a step
/// test or the response does not cross its levels.
pub(super) fn two_point_start(p: &Problem<'_>) -> Option<Vec<f64>> {
    if p.nu != 1 {
        return None;
    }
    for (us, y) in p.inputs.iter().zip(&p.outputs) {
        let u = &us[0];
        let changes: Vec<usize> = (1..u.len()).filter(|&t| u[t] != u[t - 1]).collect();
        let [k0] = changes[..] else { continue };
        let du = u[k0] - u[k0 - 1];
        let before: Vec<f64> = y[..k0].iter().copied().filter(|v| !v.is_nan()).collect();
        let base = if before.is_empty() {
            0.0
        } else {
            before.iter().sum::<f64>() / before.len() as f64
        };
        // (time after the step, normalised response) at the measured samples
        let s: Vec<(f64, f64)> = (k0..y.len())
            .filter(|&t| !y[t].is_nan())
            .map(|t| ((t - k0) as f64 * p.ts, (y[t] - base) / du))
            .collect();
        if s.len() < 6 {
            continue;
        }
        let tail = &s[s.len() * 2 / 3..];
        if p.kind == ProcessKind::P1DI {
            let n = tail.len() as f64;
            let (mt, ms) = tail
                .iter()
                .fold((0.0, 0.0), |a, (t, v)| (a.0 + t / n, a.1 + v / n));
            let (sxy, sxx) = tail.iter().fold((0.0, 0.0), |a, (t, v)| {
                (a.0 + (t - mt) * (v - ms), a.1 + (t - mt) * (t - mt))
            });
            let k = sxy / sxx;
            let lag = (mt - ms / k).max(p.ts);
            return (k.is_finite() && k != 0.0).then(|| vec![k, lag / 2.0, lag / 2.0]);
        }
        let k = tail.iter().map(|(_, v)| v).sum::<f64>() / tail.len() as f64;
        if !(k.is_finite() && k != 0.0) {
            continue;
        }
        let cross = |level: f64| {
            let mut prev = (0.0, 0.0);
            for &(t, v) in &s {
                if v / k >= level {
                    let (t0, v0) = prev;
                    let f = if v / k > v0 / k {
                        (level - v0 / k) / (v / k - v0 / k)
                    } else {
                        0.0
                    };
                    return Some(t0 + f * (t - t0));
                }
                prev = (t, v);
            }
            None
        };
        let (t28, t63) = (cross(0.283)?, cross(0.632)?);
        let tau = (1.5 * (t63 - t28)).max(p.ts / 2.0);
        let theta = (t63 - tau).max(0.0);
        return Some(match p.kind {
            ProcessKind::P1D => vec![k, tau, theta],
            ProcessKind::P2D => vec![k, 0.7 * tau, 0.3 * tau, (theta - 0.15 * tau).max(0.0)],
            ProcessKind::P2DZ => vec![k, 0.7 * tau, 0.3 * tau, 0.0, (theta - 0.15 * tau).max(0.0)],
            ProcessKind::P2DU => vec![k, tau / 2.0, 0.7, theta],
            ProcessKind::P1DI => vec![k, tau, theta], // handled above
        });
    }
    None
}

/// The starts: the two-point method on a step test, then for one input the
/// best distinct grid points, for several inputs one point from two sweeps
/// of per-input grids against the others' current contributions.
pub(super) fn starts(p: &Problem<'_>, opts: &ProcessOptions) -> Result<Vec<Vec<f64>>> {
    let mut out = Vec::new();
    let b = p.block();
    if p.nu == 1 {
        let target: Vec<Vec<f64>> = p.outputs.iter().map(|y| y.to_vec()).collect();
        let cands = grid(p, 0, &target)?;
        let mut picked: Vec<&Candidate> = Vec::new();
        for c in &cands {
            if picked.len() == opts.starts {
                break;
            }
            let distinct = picked.iter().all(|q| {
                q.cell.0.abs_diff(c.cell.0) > 1
                    || q.cell.1.abs_diff(c.cell.1) > 1
                    || q.cell.2.abs_diff(c.cell.2) > 2
            });
            if distinct {
                picked.push(c);
            }
        }
        for c in picked {
            let mut s = c.block.clone();
            if p.offset {
                s.push(c.offset);
            }
            out.push(s);
        }
        if let Some(mut s) = two_point_start(p) {
            if p.offset {
                s.push(0.0);
            }
            out.push(s);
        }
        return Ok(out);
    }
    let mut blocks: Vec<Option<Vec<f64>>> = vec![None; p.nu];
    let mut offset = 0.0;
    for _sweep in 0..2 {
        for j in 0..p.nu {
            // target = y − the other inputs' current contributions
            let mut target: Vec<Vec<f64>> = p.outputs.iter().map(|y| y.to_vec()).collect();
            for (i, blk) in blocks.iter().enumerate() {
                let Some(blk) = blk else { continue };
                if i == j {
                    continue;
                }
                let m = ProcessModel::from_parameters(p.kind, blk, p.ts)?
                    .with_intersample(p.intersample);
                let dm = Discrete::new(&m)?;
                for (e, t) in target.iter_mut().enumerate() {
                    dm.add_response(&p.inputs[e][i], -1.0, t);
                }
            }
            if let Some(c) = grid(p, j, &target)?.into_iter().next() {
                blocks[j] = Some(c.block);
                offset = c.offset;
            }
        }
    }
    let mut s = Vec::with_capacity(p.n_phi());
    for blk in blocks {
        match blk {
            Some(blk) => s.extend(blk),
            None => return Ok(out),
        }
    }
    debug_assert_eq!(s.len(), p.nu * b);
    if p.offset {
        s.push(offset);
    }
    out.push(s);
    Ok(out)
}
