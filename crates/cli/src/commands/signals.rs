//! `prbs`, `rbs`, `gbn`, `gaussian`, `multisine` and `design`.

use lifted_prbs::{
    ChannelScheme, DesignRequest, ExperimentPlan, GaussianOptions, GbnOptions, InversePrbs,
    InversePrbsOptions, MSequence, MultisineOptions, PlanOptions, RandomBinaryOptions, design,
    gaussian_white, generalized_binary_noise, multisine, multisine_harmonics, random_binary,
};

use crate::args::{DesignArgs, GaussianArgs, GbnArgs, MultisineArgs, PrbsArgs, RbsArgs, SignalOut};
use crate::error::{CliResult, Context, input};
use crate::table::{names, write_columns};
use lifted_cli::shown::shown;

/// Largest number of samples the generators write (a CSV of about 2 GB).
const MAX_SAMPLES: u64 = 100_000_000;

/// The column names of the channels: `--name`/`--inputs` (comma separated)
/// and `--channels m`. One name with `m > 1` channels is numbered: its
/// trailing digits are dropped and 1…m appended (`u1` → `u1, u2, …`).
pub fn channel_names(out: &SignalOut) -> CliResult<Vec<String>> {
    let given = names(&out.name);
    let list = match (given.len(), out.channels) {
        (0, _) => return Err(input("--name: no channel name")),
        (_, Some(0)) => return Err(input("--channels must be at least 1")),
        (_, None) => given,
        (1, Some(1)) => given,
        (1, Some(m)) => {
            let stem = given[0].trim_end_matches(|c: char| c.is_ascii_digit());
            let stem = if stem.is_empty() { "u" } else { stem };
            (1..=m).map(|l| format!("{stem}{l}")).collect()
        }
        (k, Some(m)) if k == m => given,
        (k, Some(m)) => {
            return Err(input(format!(
                "--channels {m} but {k} names in --name/--inputs (give one name or one per channel)"
            )));
        }
    };
    for (i, n) in list.iter().enumerate() {
        if n == "t" {
            return Err(input("--name: 't' is the time column"));
        }
        if let Some(j) = list[..i].iter().position(|m| m == n) {
            return Err(input(format!(
                "--name: channel '{}' is named twice (positions {} and {})",
                shown(n),
                j + 1,
                i + 1
            )));
        }
    }
    Ok(list)
}

/// Writes `t` and the channels `cols` (named `names`).
fn write_signals(out: &SignalOut, names: &[String], cols: Vec<Vec<f64>>) -> CliResult<()> {
    if !(out.ts.is_finite() && out.ts > 0.0) {
        return Err(input(format!(
            "--ts {}: must be positive and finite",
            out.ts
        )));
    }
    let n = cols.first().map_or(0, Vec::len);
    let t: Vec<f64> = (0..n).map(|k| k as f64 * out.ts).collect();
    let mut header = vec!["t".to_string()];
    header.extend(names.iter().cloned());
    let mut data = vec![t];
    data.extend(cols);
    write_columns(&out.out, &header, &data)?;
    if names.len() == 1 {
        println!("wrote {n} samples to {}", out.out);
    } else {
        println!(
            "wrote {n} samples of {} channels ({}) to {}",
            names.len(),
            names.join(", "),
            out.out
        );
    }
    Ok(())
}

/// The length of `channels` channels of `len` samples each, checked
/// against [`MAX_SAMPLES`] cells in all.
fn check_cells(len: u64, channels: usize) -> CliResult<usize> {
    let cells = len.saturating_mul(channels as u64);
    if len == 0 || cells > MAX_SAMPLES {
        return Err(input(format!(
            "the signal would have {len} samples × {channels} channels = {cells} cells; allowed 1..={MAX_SAMPLES}"
        )));
    }
    Ok(len as usize)
}

/// The seed of channel `l`: `seed` itself for the first channel (one
/// channel is what it was without `--channels`), a SplitMix64 mix of
/// (`seed`, `l`) for the others, so each channel is an independent ChaCha8
/// stream (uncorrelated in expectation; the sample cross-correlation of N
/// samples is of order 1/√N).
pub fn channel_seed(seed: u64, l: usize) -> u64 {
    if l == 0 {
        return seed;
    }
    let mut z = seed ^ (l as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// `lifted prbs`. Several channels are the same sequence mutually shifted
/// (the shifted scheme of lifted-prbs' multichannel plans, Zhu 2000
/// §III.D): channel `l` is delayed by `l·d` generation samples,
/// `d = ⌊m / channels⌋`, so every pair is shifted by `1 … m−1` and its
/// zero-lag cross-correlation over a period is `−a²/m` (m-sequence) or
/// `±a²/m` (inverse PRBS, eqs. II-6, II-10) instead of `a²`.
pub fn prbs(a: &PrbsArgs) -> CliResult<()> {
    let names = channel_names(&a.out)?;
    let ch = names.len();
    let opts = InversePrbsOptions {
        order: a.order,
        amplitude: a.amplitude,
        hold: a.hold,
        taps: None,
    };
    if a.inverse {
        let p = InversePrbs::new(&opts).ctx("prbs")?;
        let len = check_cells(p.period().saturating_mul(a.periods as u64), ch)?;
        let shift = (a.seed % p.period()) as usize;
        let cols: Vec<Vec<f64>> = if ch == 1 {
            vec![p.iter().skip(shift).take(len).collect()]
        } else {
            let plan = ExperimentPlan::new(&PlanOptions {
                prbs: opts.clone(),
                amplitudes: vec![a.amplitude; ch],
                scheme: ChannelScheme::Shifted,
                settle_periods: 0,
                record_periods: a.periods + usize::from(shift > 0),
            })
            .ctx("prbs --channels")?;
            let w = plan.signal();
            (0..ch)
                .map(|l| w.column(l).iter().skip(shift).take(len).copied().collect())
                .collect()
        };
        println!(
            "inverse PRBS: n = {}, m = {}, n_r = {}, a = {}, period 2 n_r m = {} samples",
            p.order(),
            p.m(),
            p.hold(),
            p.amplitude(),
            p.period()
        );
        if ch > 1 {
            println!(
                "{ch} channels, channel l delayed by l·{} generation samples (zero-lag cross-correlation ±a²/m = ±{})",
                p.m() as usize / ch,
                a.amplitude * a.amplitude / p.m() as f64
            );
        }
        write_signals(&a.out, &names, cols)
    } else {
        // Validate through the inverse-PRBS options (order, amplitude, hold).
        InversePrbs::new(&opts).ctx("prbs")?;
        let mut seq = MSequence::new(a.order).ctx("prbs")?;
        let m = seq.period();
        let hold = a.hold as u64;
        let len = check_cells((m * hold).saturating_mul(a.periods as u64), ch)?;
        if ch as u64 > m {
            return Err(input(format!(
                "--channels {ch}: the shifted channels of an m-sequence of period m = {m} allow at most {m} channels (raise --order)"
            )));
        }
        seq.advance(a.seed % m);
        // One period of the held sequence (m n_r ≤ len samples).
        let period = (m * hold) as usize;
        let mut one = Vec::with_capacity(period);
        while one.len() < period {
            let v = if seq.next_bit() == 1 {
                a.amplitude
            } else {
                -a.amplitude
            };
            one.extend(std::iter::repeat_n(v, a.hold));
        }
        let d = (m as usize / ch) * a.hold;
        let cols: Vec<Vec<f64>> = (0..ch)
            .map(|l| {
                let delay = (l * d) % period;
                (0..len)
                    .map(|k| one[(k % period + period - delay) % period])
                    .collect()
            })
            .collect();
        println!(
            "PRBS: n = {}, m = {m}, n_r = {}, a = {}, period n_r m = {} samples",
            a.order,
            a.hold,
            a.amplitude,
            m * hold
        );
        if ch > 1 {
            println!(
                "{ch} channels, channel l delayed by l·{} generation samples (zero-lag cross-correlation −a²/m = {})",
                m as usize / ch,
                -a.amplitude * a.amplitude / m as f64
            );
        }
        write_signals(&a.out, &names, cols)
    }
}

/// Runs `one(seed)` for every channel with its [`channel_seed`].
fn seeded_channels(
    names: &[String],
    seed: u64,
    one: impl Fn(u64) -> Result<Vec<f64>, lifted_prbs::Error>,
    what: &str,
) -> CliResult<Vec<Vec<f64>>> {
    (0..names.len())
        .map(|l| one(channel_seed(seed, l)).ctx(what))
        .collect()
}

/// `lifted rbs`.
pub fn rbs(a: &RbsArgs) -> CliResult<()> {
    let names = channel_names(&a.out)?;
    let len = check_cells(a.len as u64, names.len())?;
    let cols = seeded_channels(
        &names,
        a.seed,
        |seed| {
            random_binary(
                len,
                &RandomBinaryOptions {
                    amplitude: a.amplitude,
                    hold: a.hold,
                    seed,
                },
            )
        },
        "rbs",
    )?;
    write_signals(&a.out, &names, cols)
}

/// `lifted gbn`.
pub fn gbn(a: &GbnArgs) -> CliResult<()> {
    let names = channel_names(&a.out)?;
    let len = check_cells(a.len as u64, names.len())?;
    let cols = seeded_channels(
        &names,
        a.seed,
        |seed| {
            generalized_binary_noise(
                len,
                &GbnOptions {
                    amplitude: a.amplitude,
                    switch_probability: a.switch_probability,
                    hold: a.hold,
                    seed,
                },
            )
        },
        "gbn",
    )?;
    write_signals(&a.out, &names, cols)
}

/// `lifted gaussian`.
pub fn gaussian(a: &GaussianArgs) -> CliResult<()> {
    let names = channel_names(&a.out)?;
    let len = check_cells(a.len as u64, names.len())?;
    let cols = seeded_channels(
        &names,
        a.seed,
        |seed| {
            gaussian_white(
                len,
                &GaussianOptions {
                    std: a.std,
                    hold: a.hold,
                    seed,
                },
            )
        },
        "gaussian",
    )?;
    write_signals(&a.out, &names, cols)
}

/// `lifted multisine`. Several channels get "zippered" harmonic sets:
/// channel `l` of `m` excites `first + l, first + l + m, …` up to `last`
/// (Pintelon & Schoukens, System Identification, 2nd ed., §3.7), so the
/// channels are orthogonal over every whole period — zero cross-correlation
/// at every lag — and each keeps the RMS value `a`.
pub fn multisine_cmd(a: &MultisineArgs) -> CliResult<()> {
    let names = channel_names(&a.out)?;
    let ch = names.len();
    let len = check_cells(a.len as u64, ch)?;
    let opts = MultisineOptions {
        amplitude: a.amplitude,
        period: a.period,
        first_harmonic: a.first_harmonic,
        last_harmonic: a.last_harmonic,
    };
    if ch == 1 {
        let w = multisine(len, &opts).ctx("multisine")?;
        return write_signals(&a.out, &names, vec![w]);
    }
    let first = a.first_harmonic;
    let last = a
        .last_harmonic
        .unwrap_or(a.period.div_ceil(2).saturating_sub(1));
    let count = (last + 1).saturating_sub(first);
    if count < ch {
        return Err(input(format!(
            "--channels {ch}: the harmonics {first}..={last} give {count}; each channel needs at least one              (raise --period or --last-harmonic)"
        )));
    }
    let cols = (0..ch)
        .map(|l| {
            let h: Vec<usize> = (first + l..=last).step_by(ch).collect();
            multisine_harmonics(len, a.amplitude, a.period, &h).ctx("multisine")
        })
        .collect::<CliResult<Vec<_>>>()?;
    println!(
        "{ch} channels on zippered harmonics: channel l excites {first} + l, {first} + l + {ch}, … ≤ {last} of the period {}",
        a.period
    );
    write_signals(&a.out, &names, cols)
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
