//! The compact binary form (CBOR, `ciborium`) of the states that cross a
//! process boundary: partial compressions and the (B, D, x₀) regression
//! stream.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub(crate) fn to_cbor<T: Serialize>(value: &T) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    ciborium::into_writer(value, &mut out).map_err(|e| Error::InvalidOption {
        what: "serialisation",
        reason: e.to_string(),
    })?;
    Ok(out)
}

pub(crate) fn from_cbor<T: for<'de> Deserialize<'de>>(
    bytes: &[u8],
    what: &'static str,
) -> Result<T> {
    ciborium::from_reader(bytes).map_err(|e| Error::InvalidOption {
        what,
        reason: format!("cannot decode: {e}"),
    })
}
