//! Data paths of `--data`: wildcard patterns expanded (`hist-*.npy`: `*`
//! and `?` in the file name, sorted by name), and the shards of one record
//! (`--concat`) joined in order.

use lifted_lti::Dataset;
use nalgebra::DMatrix;

use crate::error::{CliResult, Context, input};
use crate::shown::shown;
use crate::table::Loaded;

/// Whether `name` matches `pattern` (`*`: any run, `?`: one character).
fn matches(pattern: &[char], name: &[char]) -> bool {
    match (pattern.first(), name.first()) {
        (None, None) => true,
        (Some('*'), _) => {
            matches(&pattern[1..], name) || (!name.is_empty() && matches(pattern, &name[1..]))
        }
        (Some('?'), Some(_)) => matches(&pattern[1..], &name[1..]),
        (Some(p), Some(n)) if p == n => matches(&pattern[1..], &name[1..]),
        _ => false,
    }
}

/// The paths of `--data` with every pattern holding `*` or `?` in its file
/// name replaced by the matching files of its folder in name order; a
/// pattern that matches nothing is an error naming it. Other paths are
/// kept as given (the loader reports a missing file).
pub fn expand(paths: &[String]) -> CliResult<Vec<String>> {
    let mut out = Vec::new();
    for p in paths {
        let path = std::path::Path::new(p);
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if !name.contains(['*', '?']) {
            out.push(p.clone());
            continue;
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        let pattern: Vec<char> = name.chars().collect();
        let mut found: Vec<String> = std::fs::read_dir(&dir)
            .ctx(format!("--data {}: cannot read its folder", shown(p)))?
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .filter_map(|e| {
                let n = e.file_name().to_str()?.to_string();
                let chars: Vec<char> = n.chars().collect();
                matches(&pattern, &chars).then(|| dir.join(n).to_string_lossy().into_owned())
            })
            .collect();
        if found.is_empty() {
            return Err(input(format!("--data {}: no file matches", shown(p))));
        }
        found.sort();
        out.extend(found);
    }
    Ok(out)
}

/// The shards of one record, in order, as one data set: same channels and
/// sample period required. O(N (n_u + n_y)) copy.
pub fn join(shards: Vec<Loaded>, paths: &[String]) -> CliResult<Loaded> {
    let mut it = shards.into_iter();
    let Some(first) = it.next() else {
        return Err(input("--concat: no data file"));
    };
    let rest: Vec<Loaded> = it.collect();
    if rest.is_empty() {
        return Ok(first);
    }
    let d0 = &first.data;
    let names = |d: &Dataset| {
        (
            d.inputs()
                .iter()
                .map(|c| c.name.clone())
                .collect::<Vec<_>>(),
            d.outputs()
                .iter()
                .map(|c| c.name.clone())
                .collect::<Vec<_>>(),
        )
    };
    for (k, l) in rest.iter().enumerate() {
        let d = &l.data;
        if names(d) != names(d0) || l.extra.ncols() != first.extra.ncols() {
            return Err(input(format!(
                "--concat: {} has other columns than {}",
                shown(&paths[k + 1]),
                shown(&paths[0])
            )));
        }
        if (d.ts() - d0.ts()).abs() > 1e-9 * d0.ts().abs() {
            return Err(input(format!(
                "--concat: {} has sample period {} s, {} has {} s",
                shown(&paths[k + 1]),
                d.ts(),
                shown(&paths[0]),
                d0.ts()
            )));
        }
    }
    let all: Vec<&Loaded> = std::iter::once(&first).chain(rest.iter()).collect();
    let stack = |get: &dyn Fn(&Loaded) -> &DMatrix<f64>| {
        let rows: usize = all.iter().map(|l| get(l).nrows()).sum();
        let cols = get(all[0]).ncols();
        let mut m = DMatrix::zeros(rows, cols);
        let mut r = 0;
        for l in &all {
            let g = get(l);
            m.rows_mut(r, g.nrows()).copy_from(g);
            r += g.nrows();
        }
        m
    };
    let u = stack(&|l| l.data.u());
    let y = stack(&|l| l.data.y());
    let extra = stack(&|l| &l.extra);
    let data =
        Dataset::new(d0.ts(), u, y, d0.inputs().to_vec(), d0.outputs().to_vec()).ctx("--concat")?;
    Ok(Loaded { data, extra })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_match_as_in_a_shell() {
        let m = |p: &str, n: &str| {
            matches(
                &p.chars().collect::<Vec<_>>(),
                &n.chars().collect::<Vec<_>>(),
            )
        };
        assert!(m("hist-*.npy", "hist-000.npy"));
        assert!(m("hist-??.npy", "hist-01.npy"));
        assert!(!m("hist-??.npy", "hist-001.npy"));
        assert!(m("*", "anything"));
        assert!(!m("*.csv", "a.npy"));
        assert!(m("a*b*c", "axxbyyc"));
    }
}
