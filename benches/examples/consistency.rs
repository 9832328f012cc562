//! Consistency of the subspace routes as the record grows (issue 15): the
//! median over seeds of the largest pole error and of the relative
//! frequency-response error of [`lifted_benches::peer_system`] (2×2, order
//! 4, random binary inputs, white output noise σ = 0.1, horizon 20) for the
//! default route (shift invariance, correlation compression, output-error
//! (B, D)), the same with the QR compression (the accurate reference), the
//! streamed route ((B, D) by the Γ⊥ projection) and the state-sequence
//! route. Not a test: it prints a table (the figures are in
//! benches/results/peers-simulated.md).
//!
//! ```text
//! cargo run --release -p lifted-benches --example consistency -- [seeds] [max_exponent]
//! ```

use lifted_benches::{peer_data, peer_system};
use lifted_lti::StateSpace;
use lifted_subspace::{
    Compression, Experiment, Feedthrough, OrderSelection, StreamingIdentifier, SubspaceOptions,
    SystemEstimate, identify,
};

/// Largest |true − estimated| pole after greedy nearest matching.
fn pole_error(est: &StateSpace) -> f64 {
    let truth = peer_system().poles().expect("poles");
    let mut left = est.poles().expect("poles");
    let mut worst: f64 = 0.0;
    for t in truth {
        let (i, d) = left
            .iter()
            .enumerate()
            .map(|(i, e)| (i, (e - t).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("same order");
        worst = worst.max(d);
        left.remove(i);
    }
    worst
}

/// Max over a 64-point grid of |G − Ĝ| / max|G|.
fn response_error(est: &StateSpace) -> f64 {
    let w: Vec<f64> = (0..64).map(|k| 0.001 + k as f64 * 3.1 / 63.0).collect();
    let g = peer_system().freqresp(&w).expect("freqresp");
    let h = est.freqresp(&w).expect("freqresp");
    g.iter()
        .zip(&h)
        .map(|(a, b)| {
            let scale = a.iter().map(|v| v.norm()).fold(0.0, f64::max);
            (a - b).iter().map(|v| v.norm()).fold(0.0, f64::max) / scale
        })
        .fold(0.0, f64::max)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let max_exp: u32 = args.get(2).map_or(Ok(6), |s| s.parse())?;
    let base = SubspaceOptions {
        order: OrderSelection::Fixed(4),
        past: 20,
        future: 20,
        feedthrough: Feedthrough::Zero,
        noise_model: false,
        ..Default::default()
    };
    let routes: Vec<(&str, SubspaceOptions, bool)> = vec![
        ("default (shift, correlation)", base.clone(), false),
        (
            "shift, QR reference",
            SubspaceOptions {
                compression: Compression::Qr,
                ..base.clone()
            },
            false,
        ),
        ("shift, streamed (projection B, D)", base.clone(), true),
        (
            "state sequence",
            SubspaceOptions {
                system: SystemEstimate::StateSequence,
                ..base.clone()
            },
            false,
        ),
    ];
    println!("| N | route | median pole error | median FR error |");
    println!("|---|---|---|---|");
    for e in 4..=max_exp {
        let n = 10usize.pow(e);
        let data: Vec<_> = (0..seeds).map(|s| peer_data(n, 0.1, 1000 + s)).collect();
        for (name, opts, stream) in &routes {
            let mut pe = Vec::new();
            let mut fe = Vec::new();
            for (u, y) in &data {
                let fit = if *stream {
                    let mut s = StreamingIdentifier::new(2, 2, opts)?;
                    s.push(u, y)?;
                    s.finish()?
                } else {
                    identify(&[Experiment { u, y }], opts)?
                };
                pe.push(pole_error(&fit.model));
                fe.push(response_error(&fit.model));
            }
            println!(
                "| 1e{e} | {name} | {:.2e} | {:.2e} |",
                median(pe),
                median(fe)
            );
        }
    }
    Ok(())
}
