//! The service layer: load data → identify → validate → figures, shared by
//! the command's handlers and the studio; [`identify`] reads the data files
//! and runs the identification workflow of `lifted_workflow` (the layer the
//! Python package calls too); [`analysis`] gathers the model
//! analyses (norms, LQR) of `lifted analyze` / `lifted lqr`.

pub mod analysis;
pub mod bands;
pub mod figures;
pub mod identify;
pub mod models;
pub mod pairs;
pub mod report;
pub mod validation;
