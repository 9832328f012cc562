//! Issue 47: names a user typed or a file carried (column names, file
//! names) reach the report only as text. The pages are parsed with an
//! HTML5 parser, as the browser reads them, and must hold no script
//! element, event-handler attribute or script URL; the escaping functions
//! are checked the same way on arbitrary strings.

use super::*;
use crate::markup::{script_vectors, text_of};
use lifted_cli::escape;
use proptest::prelude::*;

/// Column names an attacker (or an unlucky historian export) could write.
const HOSTILE_INPUT: &str = "u\"><img src=x onerror=alert(1)>&amp;";
const HOSTILE_OUTPUT: &str = "y\"><script>document.title='X'</script>";

/// A CSV field, quoted as RFC 4180 does (quotes doubled).
fn quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

#[test]
fn a_report_with_hostile_names_runs_no_script() {
    let d = tmp("hostile-report");
    // A file name with markup in it, too: the report names the data file.
    let data = p(&d, "rec<svg onload=alert(1)>'\".csv");
    simulate(&data, rbs(1500, 7), 1, 1000.0, 3);
    let text = std::fs::read_to_string(&data).unwrap();
    let (_, rows) = text.split_once('\n').unwrap();
    let header = format!("t,{},{}", quoted(HOSTILE_INPUT), quoted(HOSTILE_OUTPUT));
    std::fs::write(&data, format!("{header}\n{rows}")).unwrap();
    let model = p(&d, "javascript:alert(1).json");
    ok(&[
        "identify",
        "--data",
        &data,
        "--inputs",
        HOSTILE_INPUT,
        "--outputs",
        HOSTILE_OUTPUT,
        "--order",
        "2",
        "--out",
        &model,
    ]);
    let page = p(&d, "report.html");
    ok(&["report", "--model", &model, "--data", &data, "--out", &page]);
    let html = std::fs::read_to_string(&page).unwrap();
    let found = script_vectors(&html, false);
    assert!(found.is_empty(), "the report can run script: {found:#?}");
    // The names are there, as text: the figure of the hostile output is
    // captioned with its name, and the file names are shown.
    let shown = text_of(&html, false);
    assert!(shown.contains(HOSTILE_OUTPUT), "output name lost");
    assert!(
        shown.contains("rec<svg onload=alert(1)>'\".csv"),
        "file name lost"
    );
    // Its figure keeps an id a link can name: only [A-Za-z0-9_-].
    let fit_id = format!("fit-{}", escape::id(HOSTILE_OUTPUT));
    assert!(
        html.contains(&format!("id=\"{fit_id}\"")),
        "no figure {fit_id}"
    );
    assert!(
        fit_id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any text escaped as element text and as both kinds of quoted
    /// attribute reads back as itself, in one element with no child
    /// element and no other attribute.
    #[test]
    fn escaped_text_reads_back_as_itself(s in any::<String>()) {
        // The HTML parser turns NUL into U+FFFD and CR LF into LF, as
        // browsers do: compare what a browser would show.
        let s: String = s.replace(['\0', '\r'], "");
        let e = escape::html(&s);
        let page = format!("<p title=\"{e}\" data-x='{e}'>{e}</p>");
        let doc = scraper::Html::parse_fragment(&page);
        let sel = scraper::Selector::parse("p").unwrap();
        let ps: Vec<_> = doc.select(&sel).collect();
        prop_assert_eq!(ps.len(), 1);
        let p = ps[0];
        prop_assert_eq!(p.value().attrs().count(), 2);
        prop_assert_eq!(p.attr("title"), Some(s.as_str()));
        prop_assert_eq!(p.attr("data-x"), Some(s.as_str()));
        prop_assert_eq!(p.children().filter(|c| c.value().is_element()).count(), 0);
        prop_assert_eq!(p.text().collect::<String>(), s);
        prop_assert!(script_vectors(&page, true).is_empty());
    }

    /// Ids hold only characters that need no escaping, and distinct texts
    /// give distinct ids.
    #[test]
    fn ids_are_plain_and_distinct(a in any::<String>(), b in any::<String>()) {
        let (ia, ib) = (escape::id(&a), escape::id(&b));
        prop_assert!(ia.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'-' || c == b'_'));
        prop_assert_eq!(ia == ib, a == b);
    }

    /// A URL from any text is either `#` or something whose scheme, as a
    /// browser reads it, cannot run script.
    #[test]
    fn urls_never_run_script(s in "(?i)(java|vb)?(script|data)?[ \t\n:]{0,3}[ -~]{0,20}") {
        let u = escape::url(&s);
        let page = format!("<a href=\"{u}\">x</a>");
        prop_assert!(script_vectors(&page, true).is_empty(), "{:?} -> {:?}", s, u);
    }
}
