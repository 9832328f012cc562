//! # lifted-data
//!
//! Reading records for every Lifted front end (the `lifted` command, its
//! studio, the benches and the fuzz targets): CSV and numpy `.npy` tables
//! read by column name ([`table`]), streamed and, for large CSV files,
//! parsed on several threads; a slowly sampled output's empty cells read
//! as missing samples (the sampling pattern by `lifted_lti::output_sampling`,
//! the time column by `lifted_lti::time_step_within`: the rules every
//! front end shares); error messages that name the file, the line and the
//! column, with the user's content shown safely ([`shown`]).
//!
//! Errors are [`Error`]: `Input` (bad input: the command's exit code 2)
//! or `Failed` (a check failed: exit code 1).
//!
//! ```
//! # fn main() -> Result<(), lifted_data::Error> {
//! let dir = std::env::temp_dir().join(format!("lifted-data-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).map_err(lifted_data::error::input)?;
//! let path = dir.join("rec.csv");
//! std::fs::write(&path, "t,u,y\n0,1,0.5\n1,-1,\n2,1,0.25\n3,1,\n")
//!     .map_err(lifted_data::error::input)?;
//! let spec = lifted_data::table::DataSpec {
//!     inputs: vec!["u".into()],
//!     outputs: vec!["y".into()],
//!     hold: 1,
//!     ..Default::default()
//! };
//! let loaded = lifted_data::table::load(path.to_str().unwrap(), &spec)?;
//! // y is measured every second sample: empty cells between.
//! assert_eq!(loaded.data.outputs()[0].period, 2);
//! assert_eq!(loaded.data.len(), 4);
//! # Ok(()) }
//! ```

pub mod error;
pub mod shown;
pub mod table;

pub use error::{Error, Result};
pub use table::npy;

/// Compiles the README example as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
