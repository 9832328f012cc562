//! User content as it appears in messages: control and invisible
//! formatting characters escaped (`\x1b`, `\u{202e}`), long text cut to a
//! bounded length with a count of what was left out, numbers of any size in
//! a bounded width. Every message of the command goes through
//! [`clean_message`] (via [`crate::error::input`] and
//! [`crate::error::Context::ctx`]); the sites that echo user content (file
//! and column names, cell text, column lists) bound it first with [`shown`]
//! and [`shown_list`], and fit percentages are printed with [`percent`].

use std::fmt::Write;

/// Characters of one echoed piece of user content (a name, a cell).
pub const MAX_SHOWN: usize = 200;

/// Characters of a whole message.
pub const MAX_MESSAGE: usize = 2000;

/// Whether `c` is shown escaped: control characters and the invisible
/// formatting characters that reorder or hide text (bidirectional
/// overrides and isolates, zero-width characters, the BOM).
fn escaped(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{feff}'
        )
}

/// Appends `c`, escaped when [`escaped`]: `\n`, `\r`, `\t`, `\x1b` below
/// U+0100, `\u{202e}` above.
fn push_char(out: &mut String, c: char) {
    if !escaped(c) {
        out.push(c);
        return;
    }
    match c {
        '\n' => out.push_str("\\n"),
        '\r' => out.push_str("\\r"),
        '\t' => out.push_str("\\t"),
        c if (c as u32) < 0x100 => {
            let _ = write!(out, "\\x{:02x}", c as u32);
        }
        c => {
            let _ = write!(out, "\\u{{{:x}}}", c as u32);
        }
    }
}

/// `s` with control characters escaped and cut after `max` characters,
/// with "… (N more characters)" when cut.
fn bounded(s: &str, max: usize) -> String {
    let mut out = String::with_capacity(s.len().min(4 * max));
    let mut chars = s.chars();
    for c in chars.by_ref().take(max) {
        push_char(&mut out, c);
    }
    let rest = chars.count();
    if rest > 0 {
        let _ = write!(out, "… ({rest} more characters)");
    }
    out
}

/// One piece of user content for a message: escaped, at most
/// [`MAX_SHOWN`] characters shown.
pub fn shown(s: &str) -> String {
    bounded(s, MAX_SHOWN)
}

/// A list of names joined by ", ", each [`shown`], the whole cut after
/// about [`MAX_SHOWN`] characters with "… and N more".
pub fn shown_list<S: AsRef<str>>(items: &[S]) -> String {
    let mut out = String::new();
    for (i, item) in items.iter().enumerate() {
        if i > 0 && out.chars().count() >= MAX_SHOWN {
            let _ = write!(out, ", … and {} more", items.len() - i);
            break;
        }
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str(&bounded(item.as_ref(), MAX_SHOWN / 4));
    }
    out
}

/// A whole message for one line: control characters escaped, every run of
/// more than [`MAX_SHOWN`] characters without a space (a long file name, an
/// unbroken cell) cut, and the total cut after [`MAX_MESSAGE`] characters.
pub fn clean_message(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len().min(4 * MAX_MESSAGE));
    let mut run = 0usize;
    let mut skipped = 0usize;
    let mut total = 0usize;
    let mut left = 0usize;
    for c in msg.chars() {
        if total >= MAX_MESSAGE {
            left += 1;
            continue;
        }
        if c == ' ' {
            if skipped > 0 {
                let _ = write!(out, "… ({skipped} more characters)");
                skipped = 0;
            }
            run = 0;
        } else {
            run += 1;
            if run > MAX_SHOWN {
                skipped += 1;
                continue;
            }
        }
        push_char(&mut out, c);
        total += 1;
    }
    if skipped > 0 {
        let _ = write!(out, "… ({skipped} more characters)");
    }
    if left > 0 {
        let _ = write!(out, "… (message cut, {left} more characters)");
    }
    out
}

/// A percentage (fit) in bounded width: two decimals below 10⁶ in
/// magnitude, else two significant digits in exponent form (`-6.0e43`).
pub fn percent(x: f64) -> String {
    if x.is_finite() && x.abs() < 1e6 {
        format!("{x:.2}")
    } else if x.is_finite() {
        format!("{x:.1e}")
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(shown("a\u{1b}[31mb\0"), "a\\x1b[31mb\\x00");
        assert_eq!(shown("x\ny\tz"), "x\\ny\\tz");
        assert_eq!(shown("\u{202e}evil"), "\\u{202e}evil");
        assert_eq!(shown("ümlaut"), "ümlaut");
    }

    #[test]
    fn long_content_is_cut_with_a_count() {
        let s = "n".repeat(5000);
        let got = shown(&s);
        assert!(got.ends_with("… (4800 more characters)"), "{got}");
        assert!(got.chars().count() < 250);
        let many: Vec<String> = (0..1000).map(|i| format!("c{i}")).collect();
        let list = shown_list(&many);
        assert!(list.chars().count() < 260, "{list}");
        assert!(list.contains("more"), "{list}");
        assert_eq!(shown_list(&["t", "u1"]), "t, u1");
    }

    #[test]
    fn messages_are_bounded() {
        let name = "f".repeat(5000);
        let m = clean_message(&format!("cannot store {name}: File name too long"));
        assert!(m.chars().count() < 300, "{}", m.len());
        assert!(m.ends_with(": File name too long") || m.contains("more characters"));
        let noise: String = (0..10_000u32)
            .map(|i| char::from_u32(i % 256).unwrap_or('?'))
            .collect();
        let m = clean_message(&noise);
        assert!(!m.chars().any(|c| c.is_control()), "{m}");
        assert!(m.chars().count() <= MAX_MESSAGE * 4 + 100);
    }

    #[test]
    fn percentages_have_bounded_width() {
        assert_eq!(percent(93.456), "93.46");
        assert_eq!(percent(-5.96e43), "-6.0e43");
        assert_eq!(percent(f64::NAN), "NaN");
        assert!(percent(-1e300).len() < 10);
    }
}
