//! The one place where text becomes markup. Everything a user typed or a
//! file carried (column and file names, units, messages, diagnostics)
//! reaches the HTML of the report, the reproduction page and the studio,
//! and the SVG of their figures, only through the function of its context:
//!
//! | context | function | what it guarantees |
//! |---|---|---|
//! | element text, quoted attribute value (`"…"` or `'…'`) | [`html`] | `& < > " '` become entities: the text can neither close the element or attribute nor open a tag |
//! | an `id` and the fragment of an `href="#…"` | [`id`] | only `[A-Za-z0-9-]` and `_XX` hex escapes: nothing to escape in any context, and distinct texts give distinct ids |
//! | a value inside `<script>` (JSON) | [`script_json`] | valid JSON whose text holds no `<`, `>`, `&` or line separators, so no `</script>` or `<!--` can end or change the script |
//! | a URL in `href`/`src` | [`url`] | only relative references and `http(s)`/`mailto` survive; `javascript:`, `data:`, `vbscript:` … become `#`; the result is escaped with [`html`] |
//!
//! Text drawn inside the SVG figures goes through plotters' SVG backend,
//! which escapes element text and attribute values the same way as
//! [`html`] (`plotters-svg` 0.3.7, `escape_and_push`); the figures' own
//! markup added here (hover titles, grouping) uses [`html`]. The tests
//! parse rendered pages with an HTML parser to check that hostile names
//! leave no script element, event-handler attribute or script URL.

/// Escapes `s` for HTML element text or a quoted attribute value (either
/// quote): `&`, `<`, `>`, `"` and `'` become entities.
pub fn html(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + s.len() / 8);
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// An HTML `id` (and `#fragment`) made from any text: ASCII letters,
/// digits and `-` kept, every other byte of its UTF-8 written `_XX`
/// (lowercase hex). Injective (`_` is itself escaped, and each `_` is
/// followed by exactly two hex digits), so two names never share an id.
pub fn id(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b == b'-' {
            out.push(b as char);
        } else {
            out.push_str(&format!("_{b:02x}"));
        }
    }
    out
}

/// `value` as JSON for a `<script>` element: `<`, `>`, `&`, U+2028 and
/// U+2029 written as `\uXXXX` escapes, which JSON and JavaScript read back
/// as the same characters, so the text cannot close the element.
pub fn script_json(value: &serde_json::Value) -> String {
    let text = value.to_string();
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    out
}

/// A URL for an `href` or `src` attribute, escaped with [`html`]: a
/// relative reference (no scheme) or an `http`, `https` or `mailto` URL is
/// kept; any other scheme (`javascript:`, `data:`, `vbscript:`, with any
/// case, whitespace or control characters browsers ignore) becomes `#`.
pub fn url(s: &str) -> String {
    // Browsers drop ASCII tab and newlines anywhere in a URL and leading
    // control characters and spaces: judge the scheme on what they read.
    let seen: String = s
        .trim_start_matches(|c: char| c <= ' ')
        .chars()
        .filter(|c| !matches!(c, '\t' | '\n' | '\r'))
        .collect();
    let scheme_end = seen.find(':');
    let before_path = seen.find(['/', '?', '#']).unwrap_or(seen.len());
    let safe = match scheme_end {
        // A ':' after the first '/', '?' or '#' is part of a relative path.
        Some(colon) if colon < before_path => {
            let scheme = seen[..colon].to_ascii_lowercase();
            matches!(scheme.as_str(), "http" | "https" | "mailto")
        }
        _ => true,
    };
    if safe { html(s) } else { "#".to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn html_escapes_the_five_characters() {
        assert_eq!(
            html(r#"a<b>&"c"'d'"#),
            "a&lt;b&gt;&amp;&quot;c&quot;&#39;d&#39;"
        );
        assert_eq!(html("FIC101.OP µ°"), "FIC101.OP µ°");
    }

    #[test]
    fn ids_keep_plain_names_and_escape_the_rest() {
        assert_eq!(id("a32-lifting"), "a32-lifting");
        assert_eq!(id("y 1"), "y_201");
        assert_eq!(id("a_b"), "a_5fb");
        assert_eq!(id("µ"), "_c2_b5");
        // Injective on the classic collisions of lossy anchors.
        assert_ne!(id("a b"), id("a-b"));
        assert_ne!(id("a_20b"), id("a b"));
    }

    #[test]
    fn script_json_cannot_close_the_script() {
        let v = serde_json::json!({"name": "</script><script>alert(1)</script>\u{2028}&"});
        let s = script_json(&v);
        assert!(!s.contains('<') && !s.contains('>') && !s.contains('&'));
        let back: serde_json::Value = serde_json::from_str(&s).unwrap();
        assert_eq!(back, v);
    }

    #[test]
    fn urls_with_script_schemes_become_a_dead_link() {
        for bad in [
            "javascript:alert(1)",
            "JavaScript:alert(1)",
            " \u{1}javascript:alert(1)",
            "java\tscript:alert(1)",
            "data:text/html,<script>alert(1)</script>",
            "vbscript:msgbox(1)",
        ] {
            assert_eq!(url(bad), "#", "{bad:?}");
        }
        assert_eq!(url("#fit-y1"), "#fit-y1");
        assert_eq!(url("model.json?a=1&b=2"), "model.json?a=1&amp;b=2");
        assert_eq!(url("https://example.org/x"), "https://example.org/x");
        assert_eq!(url("./a:b"), "./a:b");
    }
}
