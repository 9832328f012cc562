//! Integration tests: every reproduction of `shared/spec/reproductions.md` must pass.
//! One module per spec section (added as the experiments land).
