//! The library part of the `lifted` command: its options (`args`), error
//! type, CSV table reader, plots and the **service layer** shared by the
//! command's handlers and by `lifted studio`:
//!
//! * [`table`]: CSV → data set (named columns, empty cells for unsampled
//!   outputs, one-line errors naming file, line and column), and
//!   [`npy`]: numpy `.npy` arrays read the same way;
//! * [`service::identify`]: data files + `identify` options → model file;
//! * [`service::validation`]: model file + record → fit and residual tests;
//! * [`service::figures`]: plots of a model and a record;
//! * [`service::report`]: the HTML report page;
//! * [`studio`]: the local web server of `lifted studio` and its JSON API;
//! * [`shown`]: user content in messages (escaped, bounded) and fit
//!   percentages in bounded width.
//!
//! No command handler calls another command's handler: each goes through
//! these modules. The fuzz targets (`fuzz/`) feed arbitrary bytes to the
//! same reader the command uses.

pub mod args;
pub mod error;
pub mod escape;
pub mod html;
pub mod plot;
pub mod service;
pub mod shards;
pub use lifted_data::shown;
pub mod studio;
pub use lifted_data::table;
/// The `.npy` reader (a part of [`table`]: the reader its `.npy` files go to).
pub use table::npy;
pub mod terminal;
