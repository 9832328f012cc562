//! The library part of the `lifted` command: its error type and the CSV
//! table reader (named columns, empty cells for unsampled outputs, one-line
//! errors naming file, line and column). The binary's command modules use
//! them through this library, and so do the fuzz targets (`fuzz/`), which
//! feed arbitrary bytes to the same reader the command uses.

pub mod error;
pub mod table;
