//! A small document model rendered both as Markdown (figures as files beside it) and as one
//! self-contained HTML page (figures inline: SVG as markup, PNG as data URIs), so the two never
//! say different things.

use std::fmt::Write;

/// A figure's content.
pub(crate) enum FigureData {
    /// SVG markup.
    Svg(String),
    /// PNG bytes.
    Png(Vec<u8>),
}

/// One block of the document.
pub(crate) enum Block {
    /// A heading of level 1 to 3.
    Heading(u8, String),
    /// A paragraph (plain text; `**bold**` is kept in Markdown and made bold in HTML).
    Para(String),
    /// A bulleted list.
    List(Vec<String>),
    /// A table with a header row.
    Table(Vec<String>, Vec<Vec<String>>),
    /// A figure saved as `figures/<file>` with a caption.
    Figure { file: String, data: FigureData, caption: String },
}

/// A document: a title and blocks.
pub(crate) struct Doc {
    pub title: String,
    pub blocks: Vec<Block>,
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

fn inline_html(s: &str) -> String {
    // **bold** -> <b>bold</b>, after escaping.
    let e = esc(s);
    let mut out = String::new();
    let mut bold = false;
    for (i, part) in e.split("**").enumerate() {
        if i > 0 {
            out.push_str(if bold { "</b>" } else { "<b>" });
            bold = !bold;
        }
        out.push_str(part);
    }
    if bold {
        out.push_str("</b>");
    }
    out
}

impl Doc {
    /// The Markdown text; figures are referenced as `figures/<file>`.
    pub(crate) fn markdown(&self) -> String {
        let mut s = format!("# {}\n\n", self.title);
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let _ = writeln!(s, "{} {t}\n", "#".repeat(*l as usize + 1));
                }
                Block::Para(t) => {
                    let _ = writeln!(s, "{t}\n");
                }
                Block::List(items) => {
                    for i in items {
                        let _ = writeln!(s, "- {i}");
                    }
                    s.push('\n');
                }
                Block::Table(h, rows) => {
                    let _ = writeln!(s, "| {} |", h.join(" | "));
                    let _ = writeln!(s, "|{}", h.iter().map(|_| "---|").collect::<String>());
                    for r in rows {
                        let _ = writeln!(s, "| {} |", r.join(" | "));
                    }
                    s.push('\n');
                }
                Block::Figure { file, caption, .. } => {
                    let _ = writeln!(s, "![{}](figures/{file})\n\n*{caption}*\n", caption.split('.').next().unwrap_or(""));
                }
            }
        }
        s
    }

    /// One self-contained HTML page.
    pub(crate) fn html(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\n<style>\
body{{font-family:DejaVu Sans,Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}}\
table{{border-collapse:collapse;margin:1em 0;font-size:0.92em}}th,td{{border:1px solid #ccc;padding:3px 8px;text-align:right}}\
th{{background:#f2f2f2}}td:first-child,th:first-child{{text-align:left}}figure{{margin:1.5em 0}}\
figcaption{{font-size:0.9em;color:#444;max-width:900px}}svg,img{{max-width:100%;height:auto}}h2{{border-bottom:1px solid #ddd}}\
</style></head><body>\n<h1>{}</h1>\n",
            esc(&self.title),
            esc(&self.title)
        );
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let _ = writeln!(s, "<h{0}>{1}</h{0}>", l + 1, esc(t));
                }
                Block::Para(t) => {
                    let _ = writeln!(s, "<p>{}</p>", inline_html(t));
                }
                Block::List(items) => {
                    s.push_str("<ul>\n");
                    for i in items {
                        let _ = writeln!(s, "<li>{}</li>", inline_html(i));
                    }
                    s.push_str("</ul>\n");
                }
                Block::Table(h, rows) => {
                    s.push_str("<table><tr>");
                    for c in h {
                        let _ = write!(s, "<th>{}</th>", esc(c));
                    }
                    s.push_str("</tr>\n");
                    for r in rows {
                        s.push_str("<tr>");
                        for c in r {
                            let _ = write!(s, "<td>{}</td>", inline_html(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</table>\n");
                }
                Block::Figure { data, caption, .. } => {
                    s.push_str("<figure>");
                    match data {
                        FigureData::Svg(svg) => {
                            s.push_str(svg.trim_start_matches(|c| c != '<').split_once("<svg").map(|(_, r)| format!("<svg{r}")).as_deref().unwrap_or(svg))
                        }
                        FigureData::Png(png) => {
                            let _ = write!(s, "<img alt=\"{}\" src=\"data:image/png;base64,{}\">", esc(caption), base64(png));
                        }
                    }
                    let _ = writeln!(s, "<figcaption>{}</figcaption></figure>", inline_html(caption));
                }
            }
        }
        s.push_str("</body></html>\n");
        s
    }

    /// The figures, as (file name, bytes).
    pub(crate) fn figure_files(&self) -> Vec<(&str, Vec<u8>)> {
        self.blocks
            .iter()
            .filter_map(|b| match b {
                Block::Figure { file, data: FigureData::Svg(svg), .. } => Some((file.as_str(), svg.clone().into_bytes())),
                Block::Figure { file, data: FigureData::Png(png), .. } => Some((file.as_str(), png.clone())),
                _ => None,
            })
            .collect()
    }
}

/// Standard base64 with padding.
pub(crate) fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= c.len() {
                out.push(T[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("fooba", "Zm9vYmE="), ("foobar", "Zm9vYmFy")] {
            assert_eq!(base64(i.as_bytes()), o);
        }
    }

    #[test]
    fn html_escapes_and_bolds() {
        let d = Doc { title: "a<b".into(), blocks: vec![Block::Para("x **y** < z".into())] };
        let h = d.html();
        assert!(h.contains("<p>x <b>y</b> &lt; z</p>") && h.contains("<title>a&lt;b</title>"));
        assert!(d.markdown().contains("x **y** < z"));
    }
}
