mod bad_input;
mod extraction;
mod procedure;
mod properties;
