//! The exception hierarchy of `lifted` and the mapping of every Rust error
//! onto it.
//!
//! ```text
//! ValueError
//! └── LiftedError                 what
//!     ├── ArgumentError           argument            (a Python argument the binding could not read)
//!     ├── DimensionError          what, expected, got
//!     ├── NonFiniteError          what, row, col, value
//!     ├── OrderError              what, order, max, rank
//!     ├── NotExcitingError        what, rank, needed
//!     ├── UnstableError           what, spectral_radius, pole
//!     ├── TooShortError           what, got, needed
//!     ├── MemoryBudgetError       what, needed_bytes, budget_bytes
//!     └── WorkBudgetError         what, flops, limit
//! ```
//!
//! The classes are created in, and registered under, `lifted._lifted` (the
//! module that holds them), so `pickle` finds them in another process. The
//! structured fields of the Rust variant become instance attributes (a
//! field the variant does not have is `None`, a class-level default), and
//! they travel with the exception through `pickle`:
//! `BaseException.__reduce__` carries the instance `__dict__`.

use pyo3::IntoPyObjectExt;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyComplex, PyType};

create_exception!(
    lifted._lifted,
    LiftedError,
    PyValueError,
    "Any error of the Lifted library (bad input or a failed computation); the message is the Rust error's. `what` names the object concerned when the Rust error does."
);
create_exception!(
    lifted._lifted,
    ArgumentError,
    LiftedError,
    "A Python argument could not be read (negative count, complex or non-numeric array, wrong number of dimensions); `argument` is its name."
);
create_exception!(
    lifted._lifted,
    DimensionError,
    LiftedError,
    "Shapes or lengths that do not fit together: `what`, `expected`, `got`."
);
create_exception!(
    lifted._lifted,
    NonFiniteError,
    LiftedError,
    "A NaN or infinite value where a finite one is needed: `what`, `row` (sample), `col` (channel), `value` (those the Rust error knows)."
);
create_exception!(
    lifted._lifted,
    OrderError,
    LiftedError,
    "A model order (or parameter count) the data or the method cannot support: `order`, `max`, `rank`."
);
create_exception!(
    lifted._lifted,
    NotExcitingError,
    LiftedError,
    "The input is not persistently exciting: `what`, numerical `rank`, `needed`."
);
create_exception!(
    lifted._lifted,
    UnstableError,
    LiftedError,
    "A stable model or loop was required: `what`, `spectral_radius` and/or an unstable `pole`."
);
create_exception!(
    lifted._lifted,
    TooShortError,
    LiftedError,
    "The record is too short for the options: `what`, `got` samples, `needed`."
);
create_exception!(
    lifted._lifted,
    MemoryBudgetError,
    LiftedError,
    "The request would allocate more than the memory budget (LIFTED_MEMORY_LIMIT, default half the physical memory): `what`, `needed_bytes`, `budget_bytes`."
);
create_exception!(
    lifted._lifted,
    WorkBudgetError,
    LiftedError,
    "The request needs more floating-point operations than the work bound: `what`, `flops`, `limit`."
);

/// The Python class an error maps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Base,
    Argument,
    Dimension,
    NonFinite,
    Order,
    NotExciting,
    Unstable,
    TooShort,
    MemoryBudget,
    WorkBudget,
}

/// Every class with the attributes it declares (class-level `None`
/// defaults, so an instance raised from Python has them too).
const CLASSES: [(Kind, &str, &[&str]); 10] = [
    (Kind::Base, "LiftedError", &["what"]),
    (Kind::Argument, "ArgumentError", &["argument"]),
    (Kind::Dimension, "DimensionError", &["expected", "got"]),
    (Kind::NonFinite, "NonFiniteError", &["row", "col", "value"]),
    (Kind::Order, "OrderError", &["order", "max", "rank"]),
    (Kind::NotExciting, "NotExcitingError", &["rank", "needed"]),
    (
        Kind::Unstable,
        "UnstableError",
        &["spectral_radius", "pole"],
    ),
    (Kind::TooShort, "TooShortError", &["got", "needed"]),
    (
        Kind::MemoryBudget,
        "MemoryBudgetError",
        &["needed_bytes", "budget_bytes"],
    ),
    (Kind::WorkBudget, "WorkBudgetError", &["flops", "limit"]),
];

impl Kind {
    fn type_object<'py>(self, py: Python<'py>) -> Bound<'py, PyType> {
        match self {
            Kind::Base => py.get_type::<LiftedError>(),
            Kind::Argument => py.get_type::<ArgumentError>(),
            Kind::Dimension => py.get_type::<DimensionError>(),
            Kind::NonFinite => py.get_type::<NonFiniteError>(),
            Kind::Order => py.get_type::<OrderError>(),
            Kind::NotExciting => py.get_type::<NotExcitingError>(),
            Kind::Unstable => py.get_type::<UnstableError>(),
            Kind::TooShort => py.get_type::<TooShortError>(),
            Kind::MemoryBudget => py.get_type::<MemoryBudgetError>(),
            Kind::WorkBudget => py.get_type::<WorkBudgetError>(),
        }
    }
}

/// Adds the classes to the module, with their attribute defaults.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    for (kind, name, attrs) in CLASSES {
        let ty = kind.type_object(py);
        for a in attrs {
            ty.setattr(*a, py.None())?;
        }
        m.add(name, ty)?;
    }
    Ok(())
}

/// The structured fields of one error, as Python objects.
pub(crate) struct Fields<'py> {
    py: Python<'py>,
    items: Vec<(&'static str, Bound<'py, PyAny>)>,
}

impl<'py> Fields<'py> {
    /// Records `name = value`.
    pub(crate) fn set<T: IntoPyObject<'py>>(&mut self, name: &'static str, value: T) -> &mut Self {
        if let Ok(v) = value.into_bound_py_any(self.py) {
            self.items.push((name, v));
        }
        self
    }

    fn complex(&mut self, name: &'static str, z: num_complex::Complex64) -> &mut Self {
        let v = PyComplex::from_doubles(self.py, z.re, z.im).into_any();
        self.items.push((name, v));
        self
    }
}

/// A Rust error type whose variants map onto [`Kind`] with their fields.
pub(crate) trait Classify: std::fmt::Display {
    /// The class, after recording the fields in `f`.
    fn classify(&self, f: &mut Fields<'_>) -> Kind;
}

/// The Python exception of a Lifted error: its class, the Rust message and
/// the fields as attributes.
pub(crate) fn err<E: Classify>(e: E) -> PyErr {
    Python::attach(|py| {
        let mut f = Fields {
            py,
            items: Vec::new(),
        };
        let kind = e.classify(&mut f);
        build(py, kind, e.to_string(), f.items)
    })
}

/// An [`ArgumentError`] for the Python argument `argument`.
pub(crate) fn arg_error(argument: &str, message: impl std::fmt::Display) -> PyErr {
    Python::attach(|py| {
        let items = match argument.into_pyobject(py) {
            Ok(a) => vec![("argument", a.into_any())],
            Err(_) => Vec::new(),
        };
        build(
            py,
            Kind::Argument,
            format!("argument '{argument}': {message}"),
            items,
        )
    })
}

/// A [`WorkBudgetError`] raised by a check of the binding itself.
pub(crate) fn work_budget(what: &'static str, flops: f64, limit: f64) -> PyErr {
    Python::attach(|py| {
        let mut f = Fields {
            py,
            items: Vec::new(),
        };
        f.set("what", what).set("flops", flops).set("limit", limit);
        let message =
            format!("{what}: about {flops:.2e} operations, more than the bound of {limit:.2e}");
        build(py, Kind::WorkBudget, message, f.items)
    })
}

/// A plain [`LiftedError`] with a message (a check of the binding itself).
pub(crate) fn lifted_error(message: impl Into<String>) -> PyErr {
    LiftedError::new_err(message.into())
}

fn build(
    py: Python<'_>,
    kind: Kind,
    message: String,
    items: Vec<(&'static str, Bound<'_, PyAny>)>,
) -> PyErr {
    let made = kind
        .type_object(py)
        .call1((message.clone(),))
        .and_then(|inst| {
            for (k, v) in items {
                inst.setattr(k, v)?;
            }
            Ok(inst)
        });
    match made {
        Ok(inst) => PyErr::from_value(inst),
        Err(_) => LiftedError::new_err(message),
    }
}

impl Classify for lifted_linalg::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_linalg::Error as E;
        match self {
            E::NonFinite { what, row, col } => {
                f.set("what", *what).set("row", *row).set("col", *col);
                Kind::NonFinite
            }
            E::NotSquare { what, rows, cols } => {
                f.set("what", *what)
                    .set("expected", "square")
                    .set("got", format!("{rows}x{cols}"));
                Kind::Dimension
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::NotEnoughData { what, got, needed } => {
                f.set("what", *what).set("got", *got).set("needed", *needed);
                Kind::TooShort
            }
            E::TooLarge {
                what,
                needed_bytes,
                budget_bytes,
            } => {
                f.set("what", *what)
                    .set("needed_bytes", *needed_bytes)
                    .set("budget_bytes", *budget_bytes);
                Kind::MemoryBudget
            }
            E::RankDeficient { what, rank, needed } => {
                f.set("what", *what)
                    .set("rank", *rank)
                    .set("needed", *needed);
                Kind::Base
            }
            E::Empty { what }
            | E::InvalidArgument { what, .. }
            | E::Singular { what, .. }
            | E::NotPositiveDefinite { what }
            | E::NoPrincipalBranch { what, .. }
            | E::NoUniqueSolution { what, .. }
            | E::NoStabilizingSolution { what, .. }
            | E::NoConvergence { what, .. }
            | E::Backend { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_lti::DataError {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_lti::DataError as E;
        match self {
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", *expected)
                    .set("got", *got);
                Kind::Dimension
            }
            E::NonFiniteInput {
                channel,
                sample,
                value,
            } => {
                f.set("what", "input")
                    .set("row", *sample)
                    .set("col", *channel)
                    .set("value", *value);
                Kind::NonFinite
            }
            E::MissingSample {
                channel,
                sample,
                value,
            } => {
                f.set("what", "output")
                    .set("row", *sample)
                    .set("col", *channel)
                    .set("value", *value);
                Kind::NonFinite
            }
            E::TooShort { what, needed, got } => {
                f.set("what", *what).set("got", *got).set("needed", *needed);
                Kind::TooShort
            }
            E::Empty => {
                f.set("what", "data set").set("got", 0).set("needed", 1);
                Kind::TooShort
            }
            E::OffsetOutOfRange { what, .. } | E::ChannelOutOfRange { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_lti::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_lti::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Data(e) => e.classify(f),
            E::NonFiniteScalar { what, value } => {
                f.set("what", *what).set("value", *value);
                Kind::NonFinite
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::Unstable { what, pole } => {
                f.set("what", *what).complex("pole", *pole);
                Kind::Unstable
            }
            E::DomainMismatch { what, .. }
            | E::NotContinuous { what }
            | E::NotDiscrete { what }
            | E::ZeroDenominator { what }
            | E::InvalidArgument { what, .. }
            | E::NotInvertible { what, .. }
            | E::Infinite { what, .. }
            | E::NoConvergence { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_lti::model_file::ModelFileError {
    fn classify(&self, _: &mut Fields<'_>) -> Kind {
        Kind::Base
    }
}

impl Classify for lifted_data::Error {
    fn classify(&self, _: &mut Fields<'_>) -> Kind {
        Kind::Base
    }
}

impl Classify for lifted_subspace::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_subspace::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Lti(e) => e.classify(f),
            E::Data(e) => e.classify(f),
            E::NonFinite { what, row, col } => {
                f.set("what", *what).set("row", *row).set("col", *col);
                Kind::NonFinite
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::HorizonTooLong {
                past,
                future,
                n_samples,
                min_samples,
            } => {
                f.set("what", "record")
                    .set("got", *n_samples)
                    .set("needed", *min_samples)
                    .set("past", *past)
                    .set("future", *future);
                Kind::TooShort
            }
            E::InstrumentTooShort {
                instrument_rows,
                needed,
            } => {
                f.set("what", "instrument")
                    .set("got", *instrument_rows)
                    .set("needed", *needed);
                Kind::TooShort
            }
            E::OrderTooLarge { order, max } => {
                f.set("what", "order").set("order", *order).set("max", *max);
                Kind::Order
            }
            E::NotExciting { what, rank, needed } => {
                f.set("what", *what)
                    .set("rank", *rank)
                    .set("needed", *needed);
                Kind::NotExciting
            }
            E::RankDeficient { what, rank, needed } => {
                f.set("what", *what)
                    .set("rank", *rank)
                    .set("needed", *needed);
                Kind::Base
            }
            E::Unstable { spectral_radius } => {
                f.set("what", "identified A")
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::UnstableEstimate {
                stage,
                spectral_radius,
                samples,
                growth,
                max_growth,
            } => {
                f.set("what", *stage)
                    .set("spectral_radius", *spectral_radius)
                    .set("samples", *samples)
                    .set("growth", *growth)
                    .set("max_growth", *max_growth);
                Kind::Unstable
            }
            E::InvalidHorizon { what, .. } | E::InvalidOption { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_pem::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_pem::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Lti(e) => e.classify(f),
            E::Subspace(e) => e.classify(f),
            E::NonFinite { what, row, col } => {
                f.set("what", *what).set("row", *row).set("col", *col);
                Kind::NonFinite
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::TooFewSamples {
                what,
                measured,
                needed,
            } => {
                f.set("what", *what)
                    .set("got", *measured)
                    .set("needed", *needed);
                Kind::TooShort
            }
            E::TooManyParameters {
                what,
                parameters,
                measured,
                max,
            } => {
                f.set("what", *what)
                    .set("max", *max)
                    .set("parameters", *parameters)
                    .set("measured", *measured);
                Kind::Order
            }
            E::TooMuchWork { what, flops, limit } => {
                f.set("what", *what)
                    .set("flops", *flops)
                    .set("limit", *limit);
                Kind::WorkBudget
            }
            E::Unstable { spectral_radius } => {
                f.set("what", "refinement start")
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::InvalidOption { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            // ARX/FIR regressors the data do not determine (a
            // non-exciting input, a delay longer than the record shows).
            E::RankDeficient { what, rank, needed } => {
                f.set("what", *what)
                    .set("rank", *rank)
                    .set("needed", *needed);
                Kind::NotExciting
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_multirate::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_multirate::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Lti(e) => e.classify(f),
            E::Data(e) => e.classify(f),
            E::Subspace(e) => e.classify(f),
            E::TooShort { what, got, needed } => {
                f.set("what", *what).set("got", *got).set("needed", *needed);
                Kind::TooShort
            }
            E::NonFinite { what, row, col } => {
                f.set("what", *what).set("row", *row).set("col", *col);
                Kind::NonFinite
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::OrderTooLarge { order, max } => {
                f.set("what", "order").set("order", *order).set("max", *max);
                Kind::Order
            }
            E::RankDeficient { what, rank, needed } => {
                f.set("what", *what)
                    .set("rank", *rank)
                    .set("needed", *needed);
                Kind::Base
            }
            E::Unstable {
                what,
                spectral_radius,
            } => {
                f.set("what", *what)
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::InvalidRates { what, .. }
            | E::Inconsistent { what, .. }
            | E::Unsupported { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_workflow::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_workflow::Error as E;
        match self {
            // The workflow's option names are the keyword arguments of
            // `identify`.
            E::InvalidOption { option, .. } => {
                f.set("argument", *option);
                Kind::Argument
            }
            // The class and fields of the layer below: the first error of
            // a Lifted crate down the chain of sources (a step may wrap it
            // in an error of its own that keeps it as its source).
            E::Step { source, .. } => {
                let mut next: Option<&(dyn std::error::Error + 'static)> = Some(source.as_ref());
                while let Some(s) = next {
                    if let Some(kind) = classify_layer(s, f) {
                        return kind;
                    }
                    next = s.source();
                }
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

/// The class of `s` when it is the error of a Lifted crate below the
/// workflow (None: another type).
fn classify_layer(s: &(dyn std::error::Error + 'static), f: &mut Fields<'_>) -> Option<Kind> {
    macro_rules! first_of {
        ($($t:ty),+) => {
            $(
                if let Some(e) = s.downcast_ref::<$t>() {
                    return Some(e.classify(f));
                }
            )+
        };
    }
    first_of!(
        lifted_pem::Error,
        lifted_subspace::Error,
        lifted_lti::Error,
        lifted_lti::DataError,
        lifted_multirate::Error,
        lifted_qmarkov::Error,
        lifted_prbs::Error,
        lifted_linalg::Error
    );
    None
}

impl Classify for lifted_prbs::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_prbs::Error as E;
        match self {
            E::OrderOutOfRange { order, min, max } => {
                f.set("what", "PRBS order")
                    .set("order", *order)
                    .set("max", *max)
                    .set("min", *min);
                Kind::Order
            }
            E::NonFinite { what, index } => {
                f.set("what", *what).set("row", *index);
                Kind::NonFinite
            }
            E::LengthMismatch { left, right } => {
                f.set("what", "signal lengths")
                    .set("expected", *left)
                    .set("got", *right);
                Kind::Dimension
            }
            E::ZeroFactor { what, .. }
            | E::InvalidParameter { what, .. }
            | E::EmptySignal { what }
            | E::ZeroLength { what } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_qmarkov::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_qmarkov::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Lti(e) => e.classify(f),
            E::Data(e) => e.classify(f),
            E::Prbs(e) => e.classify(f),
            E::ChannelCount {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", *expected)
                    .set("got", *got);
                Kind::Dimension
            }
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", expected)
                    .set("got", got);
                Kind::Dimension
            }
            E::NonFinite {
                experiment,
                what,
                sample,
                channel,
            } => {
                f.set("what", *what)
                    .set("row", *sample)
                    .set("col", *channel)
                    .set("experiment", *experiment);
                Kind::NonFinite
            }
            E::RecordTooShort {
                experiment,
                len,
                period,
            } => {
                f.set("what", "record")
                    .set("got", *len)
                    .set("needed", *period)
                    .set("experiment", *experiment);
                Kind::TooShort
            }
            E::OrderExceedsRank { order, rank } => {
                f.set("what", "order")
                    .set("order", *order)
                    .set("rank", *rank)
                    .set("max", *rank);
                Kind::Order
            }
            E::UnstableCover { spectral_radius } => {
                f.set("what", "q-Markov cover")
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::InvalidOption { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_sim::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_sim::Error as E;
        match self {
            E::Lti(e) => e.classify(f),
            E::Data(e) => e.classify(f),
            E::Linalg(e) => e.classify(f),
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", *expected)
                    .set("got", *got);
                Kind::Dimension
            }
            E::NonFinite { what, value } => {
                f.set("what", *what).set("value", *value);
                Kind::NonFinite
            }
            E::UnstableLoop { spectral_radius } => {
                f.set("what", "one-period map")
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::Diverged {
                sample,
                signal,
                value,
                limit,
            } => {
                f.set("what", *signal)
                    .set("sample", *sample)
                    .set("value", *value)
                    .set("limit", *limit);
                Kind::Unstable
            }
            E::NegativeDelay { what, .. }
            | E::SamplePeriodMismatch { what, .. }
            | E::NotDiscrete { what }
            | E::Unsupported { what } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}

impl Classify for lifted_mpc::Error {
    fn classify(&self, f: &mut Fields<'_>) -> Kind {
        use lifted_mpc::Error as E;
        match self {
            E::Linalg(e) => e.classify(f),
            E::Lti(e) => e.classify(f),
            E::Multirate(e) => e.classify(f),
            E::DimensionMismatch {
                what,
                expected,
                got,
            } => {
                f.set("what", *what)
                    .set("expected", *expected)
                    .set("got", *got);
                Kind::Dimension
            }
            E::NonFinite { what } => {
                f.set("what", *what);
                Kind::NonFinite
            }
            E::Unstable {
                what,
                spectral_radius,
            } => {
                f.set("what", *what)
                    .set("spectral_radius", *spectral_radius);
                Kind::Unstable
            }
            E::TooMuchWork {
                what, flops, limit, ..
            } => {
                f.set("what", *what)
                    .set("flops", *flops)
                    .set("limit", *limit);
                Kind::WorkBudget
            }
            E::NotPositiveDefinite { what, .. }
            | E::InvalidModel { what, .. }
            | E::InvalidConstraint { what, .. }
            | E::InvalidArgument { what, .. }
            | E::NoConvergence { what, .. } => {
                f.set("what", *what);
                Kind::Base
            }
            _ => Kind::Base,
        }
    }
}
