//! The HTML pages armcal writes (`diagnose --html`, `plan --html`): one
//! self-contained file each, opening offline, with the same head and style.

/// Text made safe for HTML.
pub fn html_escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The start of a page titled `armcal VERB: NAME` (`verb`, `name`; the name
/// escaped): doctype, head with the reports' one style, and the body's
/// `<h1>armcal VERB</h1>`.
pub fn page_head(verb: &str, name: &str) -> String {
    format!(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>armcal {verb}: {name}</title><style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}th{{background:#f4f4f4}}td:first-child,th:first-child{{text-align:left}}.plots{{display:flex;flex-wrap:wrap;gap:12px}}</style></head><body><h1>armcal {verb}</h1>",
        name = html_escape(name),
    )
}
