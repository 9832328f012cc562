//! The command handlers: each parses nothing itself (clap did), calls the
//! service layer of the library ([`lifted_cli::service`]) and prints or
//! writes the result. No handler calls another handler.

pub mod analyze;
pub mod closedloop;
pub mod delay;
pub mod identify;
pub mod model;
pub mod mpc;
pub mod report;
pub mod reproduce;
pub mod robust;
pub mod signals;
pub mod studio;
pub mod validate;
