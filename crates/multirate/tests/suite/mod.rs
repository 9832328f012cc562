mod bad_input;
mod delays;
mod extraction;
mod procedure;
mod properties;
