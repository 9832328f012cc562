//! Integration tests of lifted-sim (one binary, modules by area).

#[path = "suite/bad_input.rs"]
mod bad_input;
#[path = "suite/closed_loop.rs"]
mod closed_loop;
#[path = "suite/common.rs"]
mod common;
#[path = "suite/controller_rate.rs"]
mod controller_rate;
#[path = "suite/fast_path.rs"]
mod fast_path;
#[path = "suite/fixtures.rs"]
mod fixtures;
#[path = "suite/multirate.rs"]
mod multirate;
#[path = "suite/noise.rs"]
mod noise;
#[path = "suite/open_loop.rs"]
mod open_loop;
#[path = "suite/steady_state.rs"]
mod steady_state;
