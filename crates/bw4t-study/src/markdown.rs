//! Markdown of a study's pages, rendered to HTML once at load. Raw HTML in the Markdown is
//! shown as text, and links and images to a script or inline-data URL (`javascript:`,
//! `vbscript:`, `data:`) lose their target, so that the page can insert the result as it is.

use pulldown_cmark::{CowStr, Event, Options, Parser, Tag, html};

/// URL schemes that run code or hide content in a link or an image.
const UNSAFE_SCHEMES: &[&str] = &["javascript:", "vbscript:", "data:"];

/// Whether a link's target runs code. Browsers ignore ASCII whitespace and control
/// characters in a scheme and its case, so the check does too.
fn is_unsafe(url: &str) -> bool {
    let scheme: String = url
        .chars()
        .filter(|c| !c.is_ascii_whitespace() && !c.is_ascii_control())
        .take(16)
        .collect::<String>()
        .to_ascii_lowercase();
    UNSAFE_SCHEMES.iter().any(|s| scheme.starts_with(s))
}

/// `markdown` as HTML, its raw HTML escaped and its unsafe link targets emptied.
pub(crate) fn to_html(markdown: &str) -> String {
    let options = Options::ENABLE_TABLES | Options::ENABLE_STRIKETHROUGH;
    let events = Parser::new_ext(markdown, options).map(|event| match event {
        Event::Html(raw) | Event::InlineHtml(raw) => Event::Text(raw),
        Event::Start(Tag::Link { link_type, dest_url, title, id }) if is_unsafe(&dest_url) => {
            Event::Start(Tag::Link { link_type, dest_url: CowStr::Borrowed(""), title, id })
        }
        Event::Start(Tag::Image { link_type, dest_url, title, id }) if is_unsafe(&dest_url) => {
            Event::Start(Tag::Image { link_type, dest_url: CowStr::Borrowed(""), title, id })
        }
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

    #[test]
    fn script_and_data_links_and_images_lose_their_target() {
        let html = to_html(
            "[a](javascript:alert(1)) [b]( JavaScript:alert(1)) [c](vbscript:x) ![d](data:text/html,x) \
             <javascript:alert(1)>",
        );
        let lower = html.to_ascii_lowercase();
        for bad in ["href=\"javascript", "href=\"vbscript", "src=\"data:"] {
            assert!(!lower.contains(bad), "{bad} in {html}");
        }
        assert_eq!(lower.matches("href=\"\"").count(), 4, "{html}");
        assert!(html.contains(r#"<a href="">a</a>"#), "the text stays: {html}");
        let kept = to_html("[ok](https://example.org/x) [mail](mailto:a@b.c) [rel](/study)");
        for good in ["https://example.org/x", "mailto:a@b.c", "/study"] {
            assert!(kept.contains(&format!("href=\"{good}\"")), "{good} in {kept}");
        }
    }
}
