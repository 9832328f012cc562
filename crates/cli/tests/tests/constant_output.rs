use super::*;

#[test]
fn a_stuck_sensor_is_named_and_its_fit_reads_not_applicable() {
    let d = tmp("constant-output");
    let (id, _) = single_rate_data(&d);
    let (head, cols) = read_csv(&id);
    let stuck = p(&d, "stuck.csv");
    let mut text = format!("{},y2\n", head.join(","));
    for k in 0..cols[0].len() {
        let row: Vec<String> = cols.iter().map(|c| c[k].to_string()).collect();
        text += &format!("{},3\n", row.join(","));
    }
    std::fs::write(&stuck, text).unwrap();
    let model = p(&d, "m.json");
    let o = lifted(&[
        "identify",
        "--data",
        &stuck,
        "--inputs",
        "u1",
        "--outputs",
        "y1,y2",
        "--order",
        "2",
        "--out",
        &model,
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: output 2 is constant over the records (always 3)"),
        "{err}"
    );
    let table = ok(&["validate", "--model", &model, "--data", &stuck]);
    let y2 = table.lines().find(|l| l.starts_with("y2")).expect("y2 row");
    assert!(y2.contains("n/a: constant output"), "{table}");
    assert!(!y2.contains("yes") && !y2.contains("NaN"), "{table}");
}
