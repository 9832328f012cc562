use super::*;
use crate::args::IdentifyArgs;
use crate::args::{Cli, Command};
use clap::Parser;

#[test]
fn names_are_made_safe() {
    assert_eq!(safe_name("../../etc/passwd"), "passwd");
    assert_eq!(safe_name("my data (1).csv"), "my_data__1_.csv");
    assert_eq!(safe_name(".."), "data.csv");
    assert_eq!(safe_name("C:\\x\\rec.csv"), "rec.csv");
}

/// The arguments the studio builds from a request are those its shown
/// command line parses to, field by field, for requests that set every
/// option the page has (and none); a name the command does not take is
/// refused naming the field.
#[test]
fn the_request_builds_the_shown_command_s_arguments() {
    let parsed = |r: &Request, data: &[String]| -> IdentifyArgs {
        let words = Session::identify_words(r, data, "model.json");
        match Cli::try_parse_from(std::iter::once("lifted".to_string()).chain(words)) {
            Ok(Cli {
                command: Command::Identify(a),
            }) => a,
            other => panic!("{other:?}"),
        }
    };
    let data = vec!["rec.csv".to_string(), "two.csv".to_string()];
    let full = Request {
        inputs: vec!["u1".into(), "u 2".into()],
        outputs: vec!["y1".into()],
        ts: Some(0.5),
        hold: Some(3),
        output_period: vec!["y1=3".into()],
        method: Some("qmarkov".into()),
        order: Some("4".into()),
        max_order: Some(7),
        horizon: Some(12),
        q: Some(30),
        prbs_order: Some(6),
        amplitude: Some(-0.5),
        output_weight: vec![1.0, 2.5],
        instrument: vec!["r1".into(), "r2".into()],
        detrend: Some("linear".into()),
        estimator: Some("states".into()),
        order_criterion: Some("gap".into()),
        stable: true,
        feedthrough: Some(false),
        refine: Some("pem".into()),
        ..Request::default()
    };
    let iv = Request {
        method: Some("iv".into()),
        feedthrough: Some(true),
        order: Some("auto".into()),
        ..Request::default()
    };
    let regularised = Request {
        method: Some("arx".into()),
        orders: Some("20 20 1".into()),
        kernel: Some("dc".into()),
        a_structure: Some("diagonal".into()),
        ..Request::default()
    };
    let process = Request {
        method: Some("process".into()),
        process: Some("p2d".into()),
        intersample: Some("foh".into()),
        ..Request::default()
    };
    let coupled = Request {
        method: Some("armax".into()),
        orders: Some("2 2 1 1".into()),
        a_structure: Some("full".into()),
        ..Request::default()
    };
    for r in [Request::default(), full, iv, regularised, process, coupled] {
        let direct = Session::identify_args(&r, &data).expect("direct");
        assert_eq!(
            format!("{direct:?}"),
            format!("{:?}", parsed(&r, &data)),
            "{r:?}"
        );
    }
    for (field, bad) in [
        (
            "method",
            Request {
                method: Some("magic".into()),
                ..Request::default()
            },
        ),
        (
            "kernel",
            Request {
                kernel: Some("gaussian".into()),
                ..Request::default()
            },
        ),
        (
            "a_structure",
            Request {
                a_structure: Some("upper".into()),
                ..Request::default()
            },
        ),
        (
            "intersample",
            Request {
                intersample: Some("spline".into()),
                ..Request::default()
            },
        ),
        (
            "detrend",
            Request {
                detrend: Some("cubic".into()),
                ..Request::default()
            },
        ),
        (
            "refine",
            Request {
                refine: Some("harder".into()),
                ..Request::default()
            },
        ),
    ] {
        let e = Session::identify_args(&bad, &data).unwrap_err().to_string();
        assert!(e.contains(field) && e.contains("one of"), "{e}");
    }
}

#[test]
fn words_are_quoted_for_the_shell() {
    assert_eq!(shell_word("--order"), "--order");
    assert_eq!(shell_word("a b"), "'a b'");
    assert_eq!(shell_word("it's"), "'it'\\''s'");
}
