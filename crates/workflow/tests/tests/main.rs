//! The workflow crate's integration tests: the default options recover a
//! known plant; the streamed route (a record read in blocks) gives the
//! in-memory route's model; the refinement starts from exactly the plain
//! identification's model; options round-trip through JSON; bad options
//! are named; the per-method options (PBSID's future horizon and
//! feedthrough, IV's past instrument rows) reach their routes; multirate
//! closed loops come back from the lifted IV route with their set-points
//! (module `multirate_closed_loop`, issue 46).

mod closed_loop;
mod common;
mod integrators;
mod multirate;
mod multirate_check;
mod multirate_closed_loop;
mod options;
mod order_selection;
mod polynomial;
mod refinement;
mod streamed;
