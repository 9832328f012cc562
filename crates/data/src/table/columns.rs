//! Column selection: the names of `--inputs`/`--outputs`/`--output-period`,
//! duplicate checks, and the positions of the wanted columns in a header.

use super::*;

/// Parses `name=period` pairs of `--output-period`.
pub fn parse_periods(specs: &[String]) -> crate::Result<Vec<(String, usize)>> {
    parse_name_counts(specs, "--output-period", "PERIOD", "y1=5")
}

/// Parses `name=n` pairs (n a positive integer) of the option `flag`.
pub fn parse_name_counts(
    specs: &[String],
    flag: &str,
    what: &str,
    example: &str,
) -> crate::Result<Vec<(String, usize)>> {
    specs
        .iter()
        .flat_map(|s| s.split(','))
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            // The last '=': a column name may hold one (`a=b=3` is column `a=b`).
            let (name, p) = s.rsplit_once('=').ok_or_else(|| {
                input(format!(
                    "{flag} '{s}': expected NAME={what}, e.g. {example}"
                ))
            })?;
            let n: usize = p.trim().parse().ok().filter(|&p| p > 0).ok_or_else(|| {
                input(format!(
                    "{flag} '{s}': {} must be a positive integer",
                    what.to_lowercase()
                ))
            })?;
            Ok((name.trim().to_string(), n))
        })
        .collect()
}

/// An error naming the first name of `names` that occurs twice, with both
/// 1-based positions: "`what`: column 'y1' appears twice (positions 2 and
/// 3)". Empty names (a trailing comma in a header) are not compared.
pub fn check_unique<S: AsRef<str>>(what: &str, names: &[S]) -> crate::Result<()> {
    let mut seen: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (i, n) in names.iter().enumerate() {
        let n = n.as_ref();
        if n.is_empty() {
            continue;
        }
        if let Some(first) = seen.insert(n, i) {
            return Err(input(format!(
                "{what}: column '{}' appears twice (positions {} and {})",
                shown(n),
                first + 1,
                i + 1
            )));
        }
    }
    Ok(())
}

impl DataSpec {
    /// Rejects a column selected twice among the inputs and outputs (a name
    /// in both lists, or twice in one), naming it and both places, e.g.
    /// "column 'y1' is selected twice (--outputs position 1 and --outputs
    /// position 2)". Extra columns (instruments) may repeat an input.
    pub fn check_selection(&self) -> crate::Result<()> {
        let mut seen: std::collections::HashMap<&str, (&str, usize)> =
            std::collections::HashMap::new();
        for (flag, list) in [("--inputs", &self.inputs), ("--outputs", &self.outputs)] {
            for (i, n) in list.iter().enumerate() {
                if let Some((f0, i0)) = seen.insert(n.as_str(), (flag, i)) {
                    return Err(input(format!(
                        "column '{}' is selected twice ({f0} position {} and {flag} position {})",
                        shown(n),
                        i0 + 1,
                        i + 1
                    )));
                }
            }
        }
        check_unique("--instrument", &self.extra)
    }
}

/// Splits a comma-separated list of names.
pub fn names(list: &str) -> Vec<String> {
    list.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .collect()
}

/// Positions of the `wanted` columns in a CSV header; a missing one is an
/// error naming the file and listing the columns it has.
pub(super) fn column_indices(
    path: &str,
    header: &[String],
    wanted: &[&String],
) -> crate::Result<Vec<usize>> {
    wanted
        .iter()
        .map(|name| {
            // The exact name, else a header cell `name [unit]` (the form
            // lifted's own CSV files write units in).
            let exact = header.iter().position(|h| h == *name);
            exact
                .or_else(|| header.iter().position(|h| bare_name(h) == name.as_str()))
                .ok_or_else(|| {
                    // One header cell with blanks inside: a file whose
                    // columns are separated by spaces (DaISy's own format).
                    let spaced = header.len() == 1
                        && header[0].split_whitespace().count() > 1;
                    input(format!(
                        "{}: header has no column '{}' (columns: {}){}",
                        shown(path),
                        shown(name),
                        shown_list(header),
                        if spaced {
                            "; the header is one column: columns separated by spaces are not read, separate them by commas, semicolons or tabs"
                        } else {
                            ""
                        }
                    ))
                })
        })
        .collect()
}

/// Refuses the time column among the inputs and outputs when the base
/// period is read from it (`--inputs t` gave "u is not persistently
/// exciting: numerical rank 1, 20 needed").
pub fn not_the_time_column(
    path: &str,
    header: &[String],
    idx: &[usize],
    read_time: Option<usize>,
) -> crate::Result<()> {
    match read_time {
        Some(tc) if idx.contains(&tc) => Err(input(format!(
            "{}: '{}' is the time column (the base period is read from it), not an input or output; give --ts to read it as data",
            shown(path),
            shown(&header[tc])
        ))),
        _ => Ok(()),
    }
}

/// The index of the time column `t`/`time` (any case, with or without a
/// unit: `t [s]`) of a header.
pub fn time_column(header: &[String]) -> Option<usize> {
    header.iter().position(|h| {
        let h = bare_name(h);
        h.eq_ignore_ascii_case("t") || h.eq_ignore_ascii_case("time")
    })
}

/// A header cell without a trailing unit in brackets: `y1 [degC]` → `y1`
/// (the cell itself when it has none).
pub fn bare_name(h: &str) -> &str {
    match h
        .trim_end()
        .strip_suffix(']')
        .and_then(|r| r.rsplit_once(" ["))
    {
        Some((name, _)) if !name.trim().is_empty() => name.trim_end(),
        _ => h,
    }
}
