//! `analyze` and `lqr`: the numbers come from the analysis service
//! ([`lifted_cli::service::analysis`]); this module prints them.

use lifted_cli::service::analysis::{
    Analysis, ComplexValue, Lqr, analyze, lqr, nyquist, weight_matrix,
};
use lifted_cli::service::models::read_model;
use num_complex::Complex64;

use crate::args::{AnalyzeArgs, LqrArgs};
use crate::error::{CliResult, Context};

/// A number in a bounded width: fixed with six decimals between 1e-4 and
/// 1e6, exponent form otherwise.
pub fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{v:.6}")
    } else {
        format!("{v:.6e}")
    }
}

fn complex(z: &ComplexValue) -> String {
    let c = Complex64::new(z.re, z.im);
    if c.im == 0.0 {
        num(c.re)
    } else if c.im > 0.0 {
        format!("{} + {}i", num(c.re), num(c.im))
    } else {
        format!("{} - {}i", num(c.re), num(-c.im))
    }
}

fn print_roots(title: &str, roots: &[ComplexValue], discrete: bool) {
    println!("{title} ({}):", roots.len());
    for z in roots {
        if discrete {
            println!("  {:<36} |z| = {}", complex(z), num(z.abs));
        } else {
            println!("  {}", complex(z));
        }
    }
}

fn print_matrix(rows: &[Vec<f64>], row_names: &[String], col_names: &[String]) {
    let width = row_names.iter().map(|n| n.len()).max().unwrap_or(0).max(4);
    print!("  {:width$}", "");
    for c in col_names {
        print!(" {c:>14}");
    }
    println!();
    for (r, name) in rows.iter().zip(row_names) {
        print!("  {name:width$}");
        for v in r {
            print!(" {:>14}", num(*v));
        }
        println!();
    }
}

fn note<'a>(a: &'a Analysis, field: &str) -> &'a str {
    a.notes
        .get(field)
        .and_then(|v| v.as_str())
        .unwrap_or("not defined")
}

fn print_analysis(path: &str, a: &Analysis) {
    let time = match a.ts {
        Some(t) => format!(
            "discrete, T = {t} s (Nyquist π/T = {} rad/s)",
            num(nyquist(t))
        ),
        None => "continuous".to_string(),
    };
    println!(
        "{path}: {time}, order {}, {} input(s) ({}), {} output(s) ({})",
        a.order,
        a.inputs.len(),
        a.inputs.join(", "),
        a.outputs.len(),
        a.outputs.join(", ")
    );
    let discrete = a.ts.is_some();
    print_roots("poles", &a.poles, discrete);
    match &a.zeros {
        Some(z) => print_roots("transmission zeros", z, discrete),
        None => println!("transmission zeros: {}", note(a, "zeros")),
    }
    let s = &a.stability;
    let verdict = if s.stable { "stable" } else { "UNSTABLE" };
    match (s.spectral_radius, s.max_real_part) {
        (Some(rho), _) => println!("stability: {verdict}, spectral radius ρ(A) = {}", num(rho)),
        (None, Some(alpha)) if a.order > 0 => {
            println!(
                "stability: {verdict}, largest real part of a pole = {}",
                num(alpha)
            )
        }
        _ => println!("stability: {verdict} (no states)"),
    }
    match &a.dc_gain {
        Some(g) => {
            println!("DC gain (rows: outputs, columns: inputs):");
            print_matrix(g, &a.outputs, &a.inputs);
        }
        None => println!("DC gain: {}", note(a, "dc_gain")),
    }
    match a.h2_norm {
        Some(v) => println!("H2 norm: {}", num(v)),
        None => println!("H2 norm: {}", note(a, "h2_norm")),
    }
    match a.hinf_norm {
        Some(h) => match h.peak_frequency {
            Some(w) => println!(
                "H∞ norm: {} at ω = {} rad/s ({} Hz)",
                num(h.norm),
                num(w),
                num(w / (2.0 * std::f64::consts::PI))
            ),
            None => println!("H∞ norm: {} as ω → ∞ (the feedthrough D)", num(h.norm)),
        },
        None => println!("H∞ norm: {}", note(a, "hinf_norm")),
    }
    match &a.hankel_singular_values {
        Some(s) => println!(
            "Hankel singular values: {}",
            s.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", ")
        ),
        None => println!(
            "Hankel singular values: {}",
            note(a, "hankel_singular_values")
        ),
    }
}

/// `lifted analyze`.
pub fn analyze_cmd(a: &AnalyzeArgs) -> CliResult<()> {
    let file = read_model(&a.model)?;
    let r = analyze(&file.model)?;
    if a.json {
        let mut v = serde_json::to_value(&r).ctx("JSON of the analysis")?;
        // A polynomial model's coefficients with their standard deviations.
        if let (Some(p), Some(obj)) = (&file.polynomial, v.as_object_mut()) {
            obj.insert(
                "polynomial".into(),
                serde_json::json!({
                    "family": p.family(),
                    "parameters": p.parameters(),
                    "std": p.std(),
                }),
            );
        }
        // A state-space model's entries' standard deviations.
        if let (Some(c), Some(obj)) = (&file.covariance, v.as_object_mut()) {
            let [a, b, cc, d] = c.entry_std();
            let rows = |m: &nalgebra::DMatrix<f64>| -> Vec<Vec<f64>> {
                m.row_iter().map(|r| r.iter().copied().collect()).collect()
            };
            obj.insert(
                "covariance".into(),
                serde_json::json!({"std": {"a": rows(&a), "b": rows(&b), "c": rows(&cc), "d": rows(&d)}}),
            );
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&v).ctx("JSON of the analysis")?
        );
    } else {
        if let Some(p) = &file.polynomial {
            println!("{}", p.present());
        } else if let Some(c) = &file.covariance {
            println!("the model's entries with their standard deviations:");
            print!("{}", c.present(&file.model).ctx("the model's covariance")?);
        }
        print_analysis(&a.model, &r);
    }
    Ok(())
}

fn print_lqr(l: &Lqr, inputs: &[String]) {
    let n = l.x.len();
    let states: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
    println!(
        "discrete LQR at T = {} s (u = −K x; DARE residual {:.1e}, {} iterations)",
        l.ts, l.residual, l.iterations
    );
    println!("gain K (rows: inputs, columns: states):");
    print_matrix(&l.k, inputs, &states);
    let show = |v: &[ComplexValue]| {
        v.iter()
            .map(|z| format!("{} (|z| {})", complex(z), num(z.abs)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!(
        "closed-loop poles λ(A − BK): {}",
        show(&l.closed_loop_poles)
    );
    println!("open-loop poles λ(A):        {}", show(&l.open_loop_poles));
}

/// `lifted lqr`.
pub fn lqr_cmd(a: &LqrArgs) -> CliResult<()> {
    let model = read_model(&a.model)?.model;
    let (inputs, _) = lifted_cli::service::models::channel_names(&model);
    let q = match &a.q {
        Some(text) => weight_matrix("--q", text, model.order())?,
        // Output weighting: xᵀCᵀCx = ‖y‖² for D = 0.
        None => model.c().transpose() * model.c(),
    };
    let r = weight_matrix("--r", &a.r, model.n_inputs())?;
    let l = lqr(&model, &q, &r)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&l).ctx("JSON of the LQR")?
        );
    } else {
        print_lqr(&l, &inputs);
    }
    Ok(())
}
