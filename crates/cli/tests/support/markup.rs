//! Reads markup as a browser does (html5ever, through `scraper`) and lists
//! whatever in it could run script: a `script` element, an event-handler
//! attribute (`on…`), or a `javascript:`/`data:`/`vbscript:` URL. Shared by
//! the CLI's and the studio's tests of hostile names (issue 47).

use scraper::{Html, Node};

/// What in `markup` (a whole page, or with `fragment` a piece inserted as
/// `innerHTML`) could run script, one line each; empty when nothing can.
pub fn script_vectors(markup: &str, fragment: bool) -> Vec<String> {
    let doc = if fragment {
        Html::parse_fragment(markup)
    } else {
        Html::parse_document(markup)
    };
    let mut found = Vec::new();
    for node in doc.tree.nodes() {
        let Node::Element(e) = node.value() else {
            continue;
        };
        let name = e.name().to_ascii_lowercase();
        if name == "script" {
            let body: String = node
                .descendants()
                .filter_map(|n| n.value().as_text().map(|t| t.to_string()))
                .collect();
            found.push(format!("a <script> element: {body:?}"));
        }
        for (attr, value) in e.attrs() {
            let attr = attr.to_ascii_lowercase();
            if attr.starts_with("on") {
                found.push(format!("<{name} {attr}={value:?}>"));
            }
            let seen: String = value
                .chars()
                .filter(|c| !c.is_whitespace() && !c.is_control())
                .collect::<String>()
                .to_ascii_lowercase();
            let url_attr = matches!(
                attr.as_str(),
                "href" | "src" | "xlink:href" | "action" | "formaction" | "data" | "srcdoc"
            );
            if url_attr
                && ["javascript:", "data:", "vbscript:"]
                    .iter()
                    .any(|s| seen.starts_with(s))
            {
                found.push(format!("<{name} {attr}={value:?}>"));
            }
        }
    }
    found
}

/// All the text of `markup` as a browser shows it (entities decoded).
pub fn text_of(markup: &str, fragment: bool) -> String {
    let doc = if fragment {
        Html::parse_fragment(markup)
    } else {
        Html::parse_document(markup)
    };
    doc.root_element().text().collect()
}
