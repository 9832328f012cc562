//! HTML building blocks of the report, the reproduction page and the
//! studio: escaping, the page skeleton, tables and `<figure>`s with inline
//! SVG.

use crate::error::CliResult;
use crate::escape::{html as esc, id as html_id};
use crate::plot::{Plot, svg};

/// A `<figure>` with an inline SVG; `id` may be any text (a column name):
/// it is written through [`crate::escape::id`].
pub fn figure(id: &str, caption: &str, plot: &Plot, w: u32, h: u32) -> CliResult<String> {
    Ok(format!(
        "<figure id=\"{}\">\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
        html_id(id),
        svg(plot, w, h)?,
        esc(caption)
    ))
}

/// A `<figure>` around an SVG document already drawn (a grid of plots).
pub fn svg_figure(id: &str, caption: &str, svg: &str) -> String {
    format!(
        "<figure id=\"{}\">\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
        html_id(id),
        svg,
        esc(caption)
    )
}

/// The page skeleton.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>\nbody {{ font-family: sans-serif; max-width: 1000px; margin: 2em auto; }}\ntable {{ border-collapse: collapse; }}\ntd, th {{ border: 1px solid #999; padding: 0.2em 0.6em; text-align: right; }}\nth {{ background: #eee; }}\ntd:first-child {{ text-align: left; }}\n.fail {{ color: #b00; font-weight: bold; }}\nfigure {{ margin: 1em 0; }}\n</style>\n</head>\n<body>\n{}\n</body>\n</html>\n",
        esc(title),
        body
    )
}

/// An HTML table.
pub fn html_table(header: &[&str], rows: &[Vec<String>], fail_col: Option<usize>) -> String {
    let mut s = String::from("<table>\n<thead><tr>");
    for h in header {
        s += &format!("<th>{}</th>", esc(h));
    }
    s += "</tr></thead>\n<tbody>\n";
    for r in rows {
        let failed = fail_col.is_some_and(|c| r.get(c).is_some_and(|v| v == "no" || v == "FAIL"));
        s += if failed {
            "<tr class=\"fail\">"
        } else {
            "<tr>"
        };
        for c in r {
            s += &format!("<td>{}</td>", esc(c));
        }
        s += "</tr>\n";
    }
    s += "</tbody>\n</table>\n";
    s
}
