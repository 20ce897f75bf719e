//! Markdown of a study's pages, rendered to HTML once at load. Raw HTML in the Markdown is
//! shown as text, so that the page can insert the result as it is.

use pulldown_cmark::{Event, Options, Parser, html};

/// `markdown` as HTML, its raw HTML escaped.
pub(crate) fn to_html(markdown: &str) -> String {
    let options = Options::ENABLE_TABLES | Options::ENABLE_STRIKETHROUGH;
    let events = Parser::new_ext(markdown, options).map(|event| match event {
        Event::Html(raw) | Event::InlineHtml(raw) => Event::Text(raw),
        other => other,
    });
    let mut out = String::with_capacity(markdown.len() * 3 / 2);
    html::push_html(&mut out, events);
    out
}

#[cfg(test)]
mod tests {
    use super::to_html;

    #[test]
    fn markdown_becomes_html_and_raw_html_is_escaped() {
        assert_eq!(to_html("# Hi\n\n**bold**"), "<h1>Hi</h1>\n<p><strong>bold</strong></p>\n");
        let html = to_html("<script>alert(1)</script>\n\nsay <b>hi</b>");
        assert!(!html.contains("<script>") && !html.contains("<b>"), "{html}");
        assert!(html.contains("&lt;script&gt;") && html.contains("&lt;b&gt;"), "{html}");
    }
}
