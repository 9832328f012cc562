use super::*;

#[test]
fn only_one_experiment() {
    let d = tmp("reproduce");
    let dir = p(&d, "out");
    let out = lifted(&["reproduce", "--only", "A3.3", "--out", &dir]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("A3.3"), "{stdout}");
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{dir}/reproductions.json")).unwrap(),
    )
    .unwrap();
    let rows = json["rows"].as_array().unwrap();
    assert!(!rows.is_empty());
    let all_pass = rows.iter().all(|r| r["pass"] == true);
    for r in rows {
        assert_eq!(r["id"], "A3.3");
        for key in [
            "experiment",
            "quantity",
            "paper",
            "reference",
            "ours",
            "tolerance",
            "pass",
        ] {
            assert!(r.get(key).is_some(), "{key} missing in {r}");
        }
    }
    assert_eq!(out.status.code(), Some(if all_pass { 0 } else { 1 }));
    let html = std::fs::read_to_string(format!("{dir}/index.html")).unwrap();
    assert!(html.contains("<table>") && html.contains("A3.3"));
    fails(
        &["reproduce", "--only", "no-such-experiment", "--out", &dir],
        2,
    );
}

#[test]
fn figures_are_drawn_and_exported() {
    let d = tmp("reproduce-figures");
    let dir = p(&d, "out");
    let out = lifted(&["reproduce", "--only", "A1.3", "--out", &dir]);
    assert_eq!(out.status.code(), Some(0));
    let html = std::fs::read_to_string(format!("{dir}/index.html")).unwrap();
    // the index links to Fig. 1, whose <figure> carries an inline SVG
    assert!(html.contains("<a href=\"#zhu-fig1\">Zhu (2000) Fig. 1</a>"));
    let start = html
        .find("<figure id=\"zhu-fig1\">")
        .expect("Fig. 1 figure");
    let fig = &html[start..start + html[start..].find("</figure>").unwrap()];
    assert!(fig.contains("<svg") && fig.contains("<figcaption>Zhu (2000) Fig. 1:"));
    // inside the experiment's section, after its table
    let section = html.find("<section id=\"exp-a13-held-prbs\">").unwrap();
    assert!(section < start && html[section..start].contains("<table>"));
    // reproductions.json carries the figure data
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{dir}/reproductions.json")).unwrap(),
    )
    .unwrap();
    let figs = json["figures"].as_array().unwrap();
    let f1 = figs.iter().find(|f| f["id"] == "zhu-fig1").unwrap();
    assert_eq!(f1["section"], "A1.3");
    assert_eq!(f1["log_y"], false);
    let curve = &f1["curves"][0];
    let (x, y) = (
        curve["x"].as_array().unwrap(),
        curve["y"].as_array().unwrap(),
    );
    let zero = x.iter().position(|v| v.as_f64() == Some(0.0)).unwrap();
    assert!((y[zero].as_f64().unwrap() - 3.0).abs() < 1e-12);
}
