mod bad_input;
mod extraction;
mod properties;
