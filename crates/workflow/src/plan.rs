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

    /// The defaults left to a run are named with what decides them on the
    /// records' shape: the budgets' bounds on either side, 2/N.
    #[test]
    fn the_plan_names_what_the_defaults_decide() {
        let o = WorkflowOptions::default();
        let shape = |samples: usize| DataShape {
            records: 1,
            samples,
            longest: samples,
            multirate: false,
            streamed: false,
        };
        let find = |p: &Plan, key: &str| -> serde_json::Value {
            p.resolved
                .iter()
                .find(|e| e.option == key)
                .map(|e| e.value.clone())
                .unwrap_or(serde_json::Value::Null)
        };
        let short = resolved_defaults(&o, &shape(1000));
        assert_eq!(
            find(&short, "integrator_tolerance"),
            serde_json::json!(0.002)
        );
        assert_eq!(find(&short, "kalman_gain_check"), serde_json::json!(true));
        assert_eq!(
            find(&short, "refinement_judge"),
            serde_json::json!("held-out blocks")
        );
        let long = resolved_defaults(&o, &shape(300_000));
        // In memory: checked on the last budgets.gain_check_samples samples;
        // streamed: not checked.
        assert_eq!(find(&long, "kalman_gain_check"), serde_json::json!(true));
        assert!(
            long.resolved
                .iter()
                .any(|e| e.option == "kalman_gain_check" && e.why.contains("last that many"))
        );
        let streamed = resolved_defaults(
            &o,
            &DataShape {
                streamed: true,
                ..shape(300_000)
            },
        );
        assert_eq!(
            find(&streamed, "kalman_gain_check"),
            serde_json::json!(false)
        );
        // The horizons searched thin out past the full search's bound.
        let horizons = |p: &Plan| {
            p.resolved
                .iter()
                .find(|e| e.option == "horizon")
                .map(|e| e.why.clone())
                .unwrap_or_default()
        };
        assert!(horizons(&short).contains("among 5, 10, 15, 20, 30"));
        assert!(
            horizons(&long).contains("among 5, 10, 15 ("),
            "{}",
            horizons(&long)
        );
        assert_eq!(
            find(&long, "refinement_judge"),
            serde_json::json!("the records")
        );
        let mut given = o.clone();
        given.identification.horizon = Some(7);
        given.identification.integrator_tolerance = Some(0.01);
        let p = resolved_defaults(&given, &shape(1000));
        assert!(
            p.resolved
                .iter()
                .all(|e| e.option != "horizon" && e.option != "integrator_tolerance")
        );
        let mr = resolved_defaults(
            &o,
            &DataShape {
                multirate: true,
                ..shape(1000)
            },
        );
        assert!(mr.route.starts_with("multirate subspace"));
    }

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

/// The shape of the records a run identifies, known before any heavy work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DataShape {
    /// Records.
    pub records: usize,
    /// Samples, all records together.
    pub samples: usize,
    /// Samples of the longest record.
    pub longest: usize,
    /// Some output is not measured at every sample (a multirate record).
    pub multirate: bool,
    /// The records are streamed from files in two passes (not in memory).
    pub streamed: bool,
}

/// What a run decides with the defaults left to it on records of a given
/// [`DataShape`] (`diagnostics.plan`): the route and, for every option
/// given as "default", the value or rule that decides it and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plan {
    /// The route the options and the records call for, in words.
    pub route: String,
    /// Records.
    pub records: usize,
    /// Samples, all records together.
    pub samples: usize,
    /// Some output is not measured at every sample.
    pub multirate: bool,
    /// The defaults resolved, in the order the run meets them.
    pub resolved: Vec<Resolved>,
}

/// One default resolved by a [`Plan`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Resolved {
    /// The option, as [`WorkflowOptions`] names it.
    pub option: String,
    /// Its value on these records (`null` where a rule decides it later,
    /// on the records themselves).
    pub value: serde_json::Value,
    /// The rule or reason.
    pub why: String,
}

impl WorkflowOptions {
    /// The options checked ([`WorkflowOptions::check`]) and resolved for
    /// records of shape `shape`: the [`Plan`] the run follows, before any
    /// heavy work. O(1).
    pub fn plan(&self, shape: &DataShape) -> crate::Result<Plan> {
        self.check()?;
        Ok(resolved_defaults(self, shape))
    }
}

/// What a run will do with the defaults left to it, said before the heavy
/// work (`diagnostics.plan`): the route, and for every option given as
/// "default" (`None` or automatic) the value or rule that decides it on
/// these records, with its reason. O(1): from the options and the
/// [`DataShape`] only. The options themselves (`diagnostics.options`) stay
/// as given, so a plan made from them decides the same way on other
/// records.
pub fn resolved_defaults(opts: &WorkflowOptions, shape: &DataShape) -> Plan {
    use crate::{Method, Order, OrderCriterion, Refine};
    let id = &opts.identification;
    let b = &opts.budgets;
    let m = id.method;
    let route = if shape.streamed {
        "single-rate subspace, streamed in two passes (structure: horizon 10, shift invariance, order by the rule asked or Bauer's SVC)"
    } else if m.is_subspace() && shape.multirate {
        "multirate subspace (lifted), the interpolated record's start beside it"
    } else if m.is_subspace() {
        "single-rate subspace in memory"
    } else if m.is_predictor_based() && shape.multirate {
        "multirate prediction-error method on the measured samples (closed loop without an instrument)"
    } else if m.is_predictor_based() {
        "predictor-based subspace (closed loop)"
    } else if m == Method::Iv && shape.multirate {
        "multirate instrumental variables (lifted)"
    } else if m == Method::Iv {
        "instrumental-variable subspace"
    } else if m == Method::Qmarkov {
        "weighted q-Markov Cover"
    } else {
        "polynomial, process or impulse-response model"
    };
    let mut out: Vec<Resolved> = Vec::new();
    let mut say = |option: &str, value: serde_json::Value, why: String| {
        out.push(Resolved {
            option: option.to_string(),
            value,
            why,
        });
    };
    if id.horizon.is_none() {
        let (value, why) = if shape.streamed {
            (
                serde_json::json!(10),
                "the streamed route's horizon".to_string(),
            )
        } else if m.is_subspace()
            && !shape.multirate
            && id.order_criterion == OrderCriterion::Validation
        {
            let among: Vec<String> = lifted_subspace::default_horizons(
                shape.samples,
                lifted_subspace::StructureOptions::default().search_samples,
            )
            .iter()
            .map(usize::to_string)
            .collect();
            (
                serde_json::Value::Null,
                format!(
                    "chosen with the order by the held-out fit among {} (records too short for held-out blocks: the smallest AICc)",
                    among.join(", ")
                ),
            )
        } else if m.is_subspace() {
            (
                serde_json::json!(10),
                "the subspace methods' default".to_string(),
            )
        } else if m == Method::Iv {
            let a = if shape.multirate { 6 } else { 8 };
            (
                serde_json::json!(a),
                "the instrumental variables' default α".to_string(),
            )
        } else if m.is_predictor_based() {
            (
                serde_json::Value::Null,
                "the past horizon by Akaike's criterion on a VARX".to_string(),
            )
        } else {
            (
                serde_json::Value::Null,
                "not used by this method".to_string(),
            )
        };
        say("horizon", value, why);
    }
    if id.order == Order::Auto && !m.is_polynomial() {
        say(
            "order",
            serde_json::Value::Null,
            format!(
                "automatic: 1 to {} by the {} rule",
                id.max_order,
                format!("{:?}", id.order_criterion).to_lowercase()
            ),
        );
    }
    if id.integrator_tolerance.is_none() {
        let (d, why) = crate::integrators::tolerance_for(opts, shape.longest);
        say("integrator_tolerance", serde_json::json!(d), why);
    }
    if id.threads.is_none() {
        let (v, why) = if shape.streamed {
            (0, "the machine's threads on a streamed record")
        } else {
            (1, "one thread in memory")
        };
        say("threads", serde_json::json!(v), why.to_string());
    }
    if id.feedthrough.is_none() && m.is_subspace() && !shape.multirate {
        let why = if shape.streamed && shape.samples > b.gain_check_samples {
            "D estimated (a streamed record over budgets.gain_check_samples)".to_string()
        } else {
            "D kept where the records support it: D free against D = 0 by the BIC of their simulation errors".to_string()
        };
        say("feedthrough", serde_json::Value::Null, why);
    }
    if m.is_subspace() && !shape.multirate && id.noise_model {
        let within = shape.samples <= b.gain_check_samples;
        let checked = within || !shape.streamed;
        say(
            "kalman_gain_check",
            serde_json::json!(checked),
            format!(
                "{} samples {} budgets.gain_check_samples = {}{}",
                shape.samples,
                if within { "≤" } else { ">" },
                b.gain_check_samples,
                match (within, checked) {
                    (true, _) => "",
                    (false, true) => ": checked on the records' last that many samples",
                    (false, false) => ": a streamed record keeps the subspace step's gain",
                }
            ),
        );
    }
    if opts.refinement.refine == Refine::Auto {
        say(
            "refine",
            serde_json::Value::Null,
            format!(
                "decided after the estimate: refined when stable and its predicted work is at most {:.0e} operations ({:.0e} for multirate joint iterations) or the records have fewer than {} samples{}",
                b.auto_refine_work,
                b.auto_refine_work_joint,
                b.auto_refine_samples,
                if shape.streamed {
                    ""
                } else {
                    "; records in memory whose refinement would cost more are refined with the iterations stopped at that work (one iteration at least when they are that short)"
                }
            ),
        );
    }
    if opts.refinement.refine != Refine::None && m.is_subspace() && !shape.multirate {
        let held_out = shape.samples <= b.refine_check_samples;
        say(
            "refinement_judge",
            serde_json::json!(if held_out {
                "held-out blocks"
            } else {
                "the records"
            }),
            format!(
                "{} samples {} budgets.refine_check_samples = {} (and six fold refinements within {:.0e} operations)",
                shape.samples,
                if held_out { "≤" } else { ">" },
                b.refine_check_samples,
                b.refine_check_work
            ),
        );
    }
    if m.is_subspace() && shape.multirate && !id.stable {
        let held_out = shape.samples <= b.refine_check_samples;
        say(
            "multirate_check",
            serde_json::json!(held_out),
            format!(
                "{} samples {} budgets.refine_check_samples = {}: {}",
                shape.samples,
                if held_out { "≤" } else { ">" },
                b.refine_check_samples,
                if held_out {
                    "the multirate route's model is kept only when six held-out blocks favour it over the single-rate model of the record with its slow outputs interpolated linearly (inputs held one sample)"
                } else {
                    "the multirate route's model is not checked against the interpolated record's"
                }
            ),
        );
    }
    if opts.validation.covariance && !m.is_polynomial() && m != Method::Process {
        let why = if shape.streamed {
            "not estimated on a streamed record (its records are not in memory)".to_string()
        } else {
            format!(
                "the covariance of (A, B, C, D) from the prediction-error Jacobian at the model, when that pass's predicted work is at most budgets.covariance_work = {:.0e} operations",
                b.covariance_work
            )
        };
        say("covariance", serde_json::json!(!shape.streamed), why);
    }
    Plan {
        route: route.to_string(),
        records: shape.records,
        samples: shape.samples,
        multirate: shape.multirate,
        resolved: out,
    }
}
