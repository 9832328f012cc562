//! Plans: the options that made a model, read back to make it again.
//!
//! Every identification records its [`WorkflowOptions`] in the model file
//! (`diagnostics.options`); a plan is that object, alone or under the key
//! `options`, or the model file itself. [`options_from_plan`] reads any of
//! the three, so `lifted identify --plan model.json` and Python's
//! `identify(u, y, plan=...)` run with exactly the options of the model,
//! and the same records give the same model bit for bit (the routes are
//! deterministic; the thread count is part of the options). Fields left out
//! take their defaults; a field the options do not have is an error naming
//! its path, so that a misspelt option cannot pass unnoticed.

use crate::{Error, Result, WorkflowOptions};

/// The options of a plan document: a model file (its
/// `diagnostics.options`), `{"options": {...}}`, or the options object
/// itself; checked as [`WorkflowOptions::check`] checks them.
///
/// Errors: [`Error::InvalidOption`] (`plan`) for a model file without
/// recorded options, a document that is not the options, or an unknown
/// field (named by its dotted path); the check's errors.
///
/// ```
/// use lifted_workflow::{WorkflowOptions, options_from_plan};
/// let mut o = WorkflowOptions::default();
/// o.identification.max_order = 6;
/// let doc = serde_json::json!({ "diagnostics": { "options": serde_json::to_value(&o).unwrap() } });
/// assert_eq!(options_from_plan(&doc).unwrap(), o);
/// let typo = serde_json::json!({ "identification": { "max_ordr": 6 } });
/// assert!(options_from_plan(&typo).unwrap_err().to_string().contains("identification.max_ordr"));
/// ```
pub fn options_from_plan(doc: &serde_json::Value) -> Result<WorkflowOptions> {
    let given = if let Some(d) = doc.get("diagnostics") {
        d.get("options").cloned().ok_or_else(|| {
            Error::option(
                "plan",
                "the model file records no options (written before they were recorded); \
                 give the options instead",
            )
        })?
    } else if let Some(o) = doc.get("options") {
        o.clone()
    } else {
        doc.clone()
    };
    let opts: WorkflowOptions = serde_json::from_value(given.clone())
        .map_err(|e| Error::option("plan", format!("not the workflow's options: {e}")))?;
    let canonical = serde_json::to_value(&opts)
        .map_err(|e| Error::option("plan", format!("the options do not serialise: {e}")))?;
    if let Some(key) = unknown_key(&given, &canonical, "") {
        return Err(Error::option("plan", format!("unknown option {key}")));
    }
    opts.check()?;
    Ok(opts)
}

/// The first key of `given` (a JSON object tree) that `canonical` does not
/// have, as a dotted path.
fn unknown_key(
    given: &serde_json::Value,
    canonical: &serde_json::Value,
    at: &str,
) -> Option<String> {
    let (serde_json::Value::Object(g), serde_json::Value::Object(c)) = (given, canonical) else {
        return None;
    };
    g.iter().find_map(|(k, v)| {
        let path = if at.is_empty() {
            k.clone()
        } else {
            format!("{at}.{k}")
        };
        match c.get(k) {
            None => Some(path),
            Some(cv) => unknown_key(v, cv, &path),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every way of giving a plan reads back the options; the ways of
    /// getting it wrong are named.
    #[test]
    fn plans_read_back_and_refusals_name_the_field() {
        let mut o = WorkflowOptions::default();
        o.identification.horizon = Some(7);
        o.budgets.auto_refine_samples = 5;
        let v = serde_json::to_value(&o).unwrap();
        for doc in [
            v.clone(),
            serde_json::json!({ "options": v.clone() }),
            serde_json::json!({ "a": [[0.5]], "diagnostics": { "options": v.clone() } }),
        ] {
            assert_eq!(options_from_plan(&doc).unwrap(), o);
        }
        // A partial plan: the rest at the defaults.
        let partial = serde_json::json!({ "identification": { "max_order": 4 } });
        assert_eq!(
            options_from_plan(&partial)
                .unwrap()
                .identification
                .max_order,
            4
        );
        let e = options_from_plan(&serde_json::json!({ "diagnostics": {} })).unwrap_err();
        assert!(e.to_string().contains("records no options"), "{e}");
        let e = options_from_plan(&serde_json::json!({ "budgets": { "nope": 1 } })).unwrap_err();
        assert!(e.to_string().contains("unknown option budgets.nope"), "{e}");
        let e = options_from_plan(&serde_json::json!({ "refinement": { "iterations": "many" } }))
            .unwrap_err();
        assert!(e.to_string().contains("not the workflow's options"), "{e}");
        let e = options_from_plan(&serde_json::json!({ "identification": { "max_order": 0 } }))
            .unwrap_err();
        assert!(e.to_string().contains("max_order"), "{e}");
    }
}
