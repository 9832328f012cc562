mod bad_input;
mod common;
mod cover;
mod mimo;
mod siso;
