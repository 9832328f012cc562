//! The fuzz targets' committed corpora, replayed through the targets' own
//! bodies (`fuzz/src/lib.rs`, included below), then a seeded mutation smoke
//! of each target: CI's fuzz smoke, inside the README's test command.
//!
//! libFuzzer (cargo-fuzz, `fuzz/README.md`) finds new inputs in long local
//! runs; its instrumented build of the whole workspace cost CI about eight
//! minutes, so CI runs the same bodies here instead: every committed input
//! (the regression part: each crash ever found is in a corpus), then
//! mutations of them (bit flips, interesting bytes, insertions, deletions,
//! splices; libFuzzer's kinds without its coverage feedback) from a fixed
//! ChaCha seed, so a red run reproduces bit for bit. A panic names the
//! target, the corpus file and the mutation.

#[allow(dead_code, missing_docs)]
#[path = "../../../fuzz/src/lib.rs"]
mod fuzz_bodies;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The committed inputs of one target, sorted by file name.
fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/corpus")
        .join(target);
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("corpus {} unreadable: {e}", dir.display()))
        .map(|entry| {
            let path = entry.expect("corpus entry").path();
            let bytes = std::fs::read(&path).expect("corpus file reads");
            (
                path.file_name().unwrap().to_string_lossy().into_owned(),
                bytes,
            )
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "corpus of {target} is empty");
    files
}

fn body(target: &str) -> fuzz_bodies::Body {
    fuzz_bodies::TARGETS
        .iter()
        .find(|(name, _)| *name == target)
        .map(|(_, f)| *f)
        .expect("a known target")
}

/// Runs one input; a panic is reported with `what` names it.
fn run(target: &str, f: fuzz_bodies::Body, bytes: &[u8], what: &dyn Fn() -> String) {
    if catch_unwind(AssertUnwindSafe(|| f(bytes))).is_err() {
        panic!(
            "fuzz target {target} panicked on {} ({} bytes: {:02x?})",
            what(),
            bytes.len(),
            &bytes[..bytes.len().min(256)]
        );
    }
}

/// One mutation of libFuzzer's kinds, in place.
fn mutate(rng: &mut ChaCha8Rng, bytes: &mut Vec<u8>, other: &[u8]) {
    const INTERESTING: [u8; 12] = [
        0, 1, 0x7f, 0x80, 0xff, b',', b'\n', b'-', b'e', b'.', b'9', b'"',
    ];
    const MAX_LEN: usize = 8192;
    let len = bytes.len();
    match rng.random_range(0..6) {
        0 if len > 0 => {
            let i = rng.random_range(0..len);
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        1 if len > 0 => {
            let i = rng.random_range(0..len);
            bytes[i] = INTERESTING[rng.random_range(0..INTERESTING.len())];
        }
        2 if len < MAX_LEN => {
            let i = rng.random_range(0..=len);
            bytes.insert(i, rng.next_u32() as u8);
        }
        3 if len > 0 => {
            let i = rng.random_range(0..len);
            let n = rng.random_range(1..=8).min(len - i);
            bytes.drain(i..i + n);
        }
        4 if !other.is_empty() && len < MAX_LEN => {
            let a = rng.random_range(0..other.len());
            let n = rng.random_range(1..=64).min(other.len() - a);
            let i = rng.random_range(0..=len);
            bytes.splice(i..i, other[a..a + n].iter().copied());
        }
        5 if len > 0 && len < MAX_LEN => {
            let a = rng.random_range(0..len);
            let n = rng.random_range(1..=32).min(len - a);
            let chunk = bytes[a..a + n].to_vec();
            let i = rng.random_range(0..=len);
            bytes.splice(i..i, chunk);
        }
        _ => bytes.push(rng.next_u32() as u8),
    }
    bytes.truncate(MAX_LEN);
}

/// Replays `target`'s corpus, then runs `mutations` mutated inputs.
fn smoke(target: &str, seed: u64, mutations: usize) {
    let f = body(target);
    let inputs = corpus(target);
    for (name, bytes) in &inputs {
        run(target, f, bytes, &|| format!("corpus file {name}"));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for m in 0..mutations {
        let base = rng.random_range(0..inputs.len());
        let other = &inputs[rng.random_range(0..inputs.len())].1;
        let mut bytes = inputs[base].1.clone();
        for _ in 0..rng.random_range(1..=4) {
            mutate(&mut rng, &mut bytes, other);
        }
        let name = &inputs[base].0;
        run(target, f, &bytes, &|| {
            format!("mutation {m} of corpus file {name} (seed {seed})")
        });
    }
}

#[test]
fn the_csv_reader_survives_its_corpus_and_mutations() {
    smoke("csv_table", 1, 10_000);
}

#[test]
fn the_npy_reader_survives_its_corpus_and_mutations() {
    smoke("npy_table", 2, 10_000);
}

#[test]
fn the_model_file_reader_survives_its_corpus_and_mutations() {
    smoke("model_file", 3, 50_000);
}

#[test]
fn identification_survives_its_corpus_and_mutations() {
    smoke("identify", 4, 20_000);
}

#[test]
fn the_identify_options_survive_their_corpus_and_mutations() {
    smoke("identify_options", 5, 60);
}

#[test]
fn lifting_survives_its_corpus_and_mutations() {
    smoke("lifting", 6, 50_000);
}
