//! Reading diagnostics: strictly (the workflow's own output) or leniently
//! (model files of older versions: an entry that no longer fits its field
//! is kept untyped). O(size of the JSON).

use serde_json::{Map, Value};

use super::{Diagnostics, FIELDS};
use crate::error::{Error, Result};

/// Every entry typed, or the first that does not fit, named.
pub(super) fn strict(v: &Value) -> Result<Diagnostics> {
    match v {
        Value::Null => Ok(Diagnostics::default()),
        Value::Object(_) => serde_json::from_value(v.clone())
            .map_err(|e| Error::Diagnostics(format!("diagnostics: {e}"))),
        other => Err(Error::Diagnostics(format!(
            "diagnostics: expected an object, found {}",
            kind(other)
        ))),
    }
}

/// As [`strict`], an entry that does not fit kept in `details` and named
/// in `unread`; a value that is not an object kept whole under `details`
/// key "diagnostics".
pub(super) fn lenient(v: &Value) -> Diagnostics {
    let map = match v {
        Value::Null => return Diagnostics::default(),
        Value::Object(m) => m,
        other => {
            let mut d = Diagnostics::default();
            d.details.insert("diagnostics".into(), other.clone());
            d.unread.push(format!(
                "diagnostics: expected an object, found {}",
                kind(other)
            ));
            return d;
        }
    };
    if let Ok(d) = serde_json::from_value::<Diagnostics>(v.clone()) {
        return d;
    }
    let mut typed = Map::new();
    let mut kept = Map::new();
    let mut unread = Vec::new();
    for (k, entry) in map {
        if !FIELDS.contains(&k.as_str()) {
            typed.insert(k.clone(), entry.clone());
            continue;
        }
        let one = Value::Object(Map::from_iter([(k.clone(), entry.clone())]));
        match serde_json::from_value::<Diagnostics>(one) {
            Ok(_) => {
                typed.insert(k.clone(), entry.clone());
            }
            Err(e) => {
                unread.push(format!("diagnostics.{k}: {e}"));
                kept.insert(k.clone(), entry.clone());
            }
        }
    }
    let mut d: Diagnostics = serde_json::from_value(Value::Object(typed)).unwrap_or_default();
    d.details.extend(kept);
    d.unread = unread;
    d
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}
