//! Which reader a data file goes to: numpy `.npy` files (by extension) to
//! [`super::npy`], everything else to the CSV readers.

use super::*;

/// Whether `path` names a numpy `.npy` file (by its extension, any case).
pub fn is_npy(path: &str) -> bool {
    std::path::Path::new(path)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
}

/// The column names of a data file: a CSV file's header row, or a `.npy`
/// file's `columns` (default `c0, c1, …`, checked against the array's
/// width). Reads only the start of the file.
pub fn header(path: &str, columns: &[String]) -> crate::Result<Vec<String>> {
    if is_npy(path) {
        return super::npy::header(path, columns);
    }
    open_csv(path, 1 << 16).map(|(_, h)| h)
}
