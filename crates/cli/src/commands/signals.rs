//! `prbs`, `rbs`, `gbn`, `gaussian`, `multisine` and `design`.

use lifted_prbs::{
    DesignRequest, GaussianOptions, GbnOptions, InversePrbs, InversePrbsOptions, MSequence,
    MultisineOptions, RandomBinaryOptions, design, gaussian_white, generalized_binary_noise,
    multisine, random_binary,
};

use crate::args::{DesignArgs, GaussianArgs, GbnArgs, MultisineArgs, PrbsArgs, RbsArgs, SignalOut};
use crate::error::{CliResult, Context, input};
use crate::table::write_columns;

/// Largest number of samples the generators write (a CSV of about 2 GB).
const MAX_SAMPLES: u64 = 100_000_000;

fn write_signal(out: &SignalOut, w: Vec<f64>) -> CliResult<()> {
    if !(out.ts.is_finite() && out.ts > 0.0) {
        return Err(input(format!(
            "--ts {}: must be positive and finite",
            out.ts
        )));
    }
    let t: Vec<f64> = (0..w.len()).map(|k| k as f64 * out.ts).collect();
    let n = w.len();
    write_columns(&out.out, &["t".to_string(), out.name.clone()], &[t, w])?;
    println!("wrote {n} samples to {}", out.out);
    Ok(())
}

fn check_len(len: u64) -> CliResult<usize> {
    if len == 0 || len > MAX_SAMPLES {
        return Err(input(format!(
            "the signal would have {len} samples; allowed 1..={MAX_SAMPLES}"
        )));
    }
    Ok(len as usize)
}

/// `lifted prbs`.
pub fn prbs(a: &PrbsArgs) -> CliResult<()> {
    let opts = InversePrbsOptions {
        order: a.order,
        amplitude: a.amplitude,
        hold: a.hold,
        taps: None,
    };
    if a.inverse {
        let p = InversePrbs::new(&opts).ctx("prbs")?;
        let len = check_len(p.period().saturating_mul(a.periods as u64))?;
        let shift = (a.seed % p.period()) as usize;
        let w: Vec<f64> = p.iter().skip(shift).take(len).collect();
        println!(
            "inverse PRBS: n = {}, m = {}, n_r = {}, a = {}, period 2 n_r m = {} samples",
            p.order(),
            p.m(),
            p.hold(),
            p.amplitude(),
            p.period()
        );
        write_signal(&a.out, w)
    } else {
        // Validate through the inverse-PRBS options (order, amplitude, hold).
        InversePrbs::new(&opts).ctx("prbs")?;
        let mut seq = MSequence::new(a.order).ctx("prbs")?;
        let m = seq.period();
        let hold = a.hold as u64;
        let len = check_len((m * hold).saturating_mul(a.periods as u64))?;
        seq.advance(a.seed % m);
        let mut w = Vec::with_capacity(len);
        while w.len() < len {
            let v = if seq.next_bit() == 1 {
                a.amplitude
            } else {
                -a.amplitude
            };
            let take = (len - w.len()).min(a.hold);
            w.extend(std::iter::repeat_n(v, take));
        }
        println!(
            "PRBS: n = {}, m = {m}, n_r = {}, a = {}, period n_r m = {} samples",
            a.order,
            a.hold,
            a.amplitude,
            m * hold
        );
        write_signal(&a.out, w)
    }
}

/// `lifted rbs`.
pub fn rbs(a: &RbsArgs) -> CliResult<()> {
    let len = check_len(a.len as u64)?;
    let w = random_binary(
        len,
        &RandomBinaryOptions {
            amplitude: a.amplitude,
            hold: a.hold,
            seed: a.seed,
        },
    )
    .ctx("rbs")?;
    write_signal(&a.out, w)
}

/// `lifted gbn`.
pub fn gbn(a: &GbnArgs) -> CliResult<()> {
    let len = check_len(a.len as u64)?;
    let w = generalized_binary_noise(
        len,
        &GbnOptions {
            amplitude: a.amplitude,
            switch_probability: a.switch_probability,
            hold: a.hold,
            seed: a.seed,
        },
    )
    .ctx("gbn")?;
    write_signal(&a.out, w)
}

/// `lifted gaussian`.
pub fn gaussian(a: &GaussianArgs) -> CliResult<()> {
    let len = check_len(a.len as u64)?;
    let w = gaussian_white(
        len,
        &GaussianOptions {
            std: a.std,
            hold: a.hold,
            seed: a.seed,
        },
    )
    .ctx("gaussian")?;
    write_signal(&a.out, w)
}

/// `lifted multisine`.
pub fn multisine_cmd(a: &MultisineArgs) -> CliResult<()> {
    let len = check_len(a.len as u64)?;
    let w = multisine(
        len,
        &MultisineOptions {
            amplitude: a.amplitude,
            period: a.period,
            first_harmonic: a.first_harmonic,
            last_harmonic: a.last_harmonic,
        },
    )
    .ctx("multisine")?;
    write_signal(&a.out, w)
}

/// `lifted design`.
pub fn design_cmd(a: &DesignArgs) -> CliResult<()> {
    let p = design(&DesignRequest {
        output_period: a.ts,
        actuator_rate_hz: a.actuator_rate,
        actuator_margin: a.actuator_margin,
        slowest_mode_hz: a.slowest_mode,
        amplitude: a.amplitude,
        min_order: a.min_order,
    })
    .ctx("design")?;
    println!("Proposed inverse PRBS (Zhu 2000 §III.D, Table II)");
    println!("  order n            {}", p.order);
    println!("  m = 2^n - 1        {}", p.m);
    println!("  hold n_r           {}", p.hold);
    println!("  magnitude a        {}", p.amplitude);
    println!("  T_p = n_r T        {} s", p.generation_period);
    println!(
        "  period 2 n_r m     {} samples = {} s",
        p.period_samples, p.record_length_s
    );
    println!("  lowest frequency   {} Hz", p.fundamental_hz);
    println!(
        "  flat band up to    {} Hz (hold null at {} Hz)",
        p.band_high_hz, p.hold_null_hz
    );
    println!();
    println!("{}", p.explanation);
    println!();
    println!(
        "generate it with: lifted prbs --inverse --order {} --hold {} --amplitude {} --ts {} --periods 2 --out u.csv",
        p.order, p.hold, p.amplitude, p.output_period
    );
    if let Some(path) = &a.json {
        let text = serde_json::to_string_pretty(&p).ctx("design")?;
        std::fs::write(path, text + "\n").ctx(format!("cannot write {path}"))?;
    }
    Ok(())
}
