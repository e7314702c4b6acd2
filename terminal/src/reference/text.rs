//! Text as the generated pages and modules need it: on one line, fit for a table cell.

/// `text` on one line.
pub(super) fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `text` fit for a table cell: one line, its pipes escaped, a rustdoc link to an item kept as
/// the item's name.
pub(super) fn cell(text: &str) -> String {
    one_line(text)
        .replace("[`", "`")
        .replace("`]", "`")
        .replace('|', "\\|")
}
