//! A tour of lifted-lti on the Zhu (2000) 1150-rpm engine model
//! (Table III, corrected per erratum Z-14):
//! G(s) = 114(3.2e-5 s² − 0.0159 s + 1)/((s/0.348 + 1)(s/15.88 + 1)).
//!
//! Run with `cargo run --release --example tour -p lifted-lti`.

use std::error::Error;

use lifted_lti::{C2dOptions, HinfOptions, MinrealOptions, Poly, TransferFunction};

fn main() -> Result<(), Box<dyn Error>> {
    let num = Poly::new(vec![3.2e-5, -0.0159, 1.0])?.scale(114.0);
    let den = &Poly::new(vec![1.0 / 0.348, 1.0])? * &Poly::new(vec![1.0 / 15.88, 1.0])?;
    let g = TransferFunction::siso(num, den, None)?;
    println!("Continuous plant (Zhu 2000, Table III, 1150 rpm):");
    println!(
        "  G(s) = {}",
        g.normalized().to_string().replace('\n', "\n         ")
    );
    let gs = g.to_ss()?;
    println!("  poles: {}", fmt_roots(&gs.poles()?));
    println!("  zeros: {}", fmt_roots(&gs.zeros()?));

    let t = 0.0113;
    let gd = gs.c2d(t, &C2dOptions::default())?;
    let gdt = gd.to_tf(&MinrealOptions::default())?.normalized();
    println!("\nZOH discretisation at T = {t} s:");
    println!("  G(z) = {}", gdt.to_string().replace('\n', "\n         "));
    println!("  poles: {}", fmt_roots(&gd.poles()?));
    println!("  (printed in the paper: (0.0198z² − 0.1949z + 0.1562)/(z² − 1.834z + 0.835);");
    println!("   the middle numerator coefficient is erratum Z-15)");

    println!("\nBode points (continuous | discrete):");
    println!(
        "  {:>9}  {:>10} {:>10}  {:>10} {:>10}",
        "ω [rad/s]", "|G|", "phase [°]", "|Gd|", "phase [°]"
    );
    let w = [0.01, 0.1, 0.348, 1.0, 10.0, 50.0];
    let bc = gs.bode(&w)?;
    let bd = gd.bode(&w)?;
    for (k, wk) in w.iter().enumerate() {
        println!(
            "  {:>9.3}  {:>10.4} {:>10.2}  {:>10.4} {:>10.2}",
            wk,
            bc.magnitude[k][(0, 0)],
            bc.phase_deg[k][(0, 0)],
            bd.magnitude[k][(0, 0)],
            bd.phase_deg[k][(0, 0)]
        );
    }

    println!(
        "\nDC gain: continuous {:.6}, discrete {:.6}",
        gs.dc_gain()?[(0, 0)],
        gd.dc_gain()?[(0, 0)]
    );
    let h2c = gs.h2_norm();
    match h2c {
        Ok(v) => println!("H2 norm (continuous): {v:.6}"),
        Err(e) => println!("H2 norm (continuous): {e}"),
    }
    println!("H2 norm (discrete):   {:.6}", gd.h2_norm()?);
    let opts = HinfOptions::default();
    let hc = gs.hinf_norm(&opts)?;
    let hd = gd.hinf_norm(&opts)?;
    println!(
        "H∞ norm (continuous): {:.6} at ω = {:.4} rad/s",
        hc.norm, hc.peak_frequency
    );
    println!(
        "H∞ norm (discrete):   {:.6} at ω = {:.4} rad/s",
        hd.norm, hd.peak_frequency
    );
    Ok(())
}

fn fmt_roots(r: &[num_complex::Complex64]) -> String {
    let mut r = r.to_vec();
    r.sort_by(|a, b| a.re.total_cmp(&b.re));
    r.iter()
        .map(|z| {
            if z.im.abs() < 1e-12 {
                format!("{:.6}", z.re)
            } else {
                format!("{:.6}{:+.6}j", z.re, z.im)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
