//! The one error a scene can give: `FILE:LINE:COL: what is wrong`.

use std::ops::Range;

/// Why a scene was refused: one message that names the file, the line and column of
/// the offending value (or of the key or table where a value is missing), and what is
/// wrong.
///
/// Displays as `FILE:LINE:COL: message`, or `FILE: message` when there is no position
/// (a file that cannot be read).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{location}: {message}")]
pub struct SceneError {
    file: String,
    line: Option<usize>,
    column: Option<usize>,
    message: String,
    /// `FILE:LINE:COL` or `FILE`, precomputed for `Display`.
    location: String,
}

impl SceneError {
    /// An error at a 1-based line and column of `file`.
    /// Control characters in `message` (and in the location) are written as escapes,
    /// so the error is always one line and cannot carry terminal escapes.
    pub fn at(file: &str, line: usize, column: usize, message: impl Into<String>) -> Self {
        Self {
            file: file.to_owned(),
            line: Some(line),
            column: Some(column),
            message: escape_controls(&message.into()),
            location: format!("{}:{line}:{column}", escape_controls(file)),
        }
    }

    /// An error about `file` as a whole, with no position.
    pub fn whole_file(file: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.to_owned(),
            line: None,
            column: None,
            message: escape_controls(&message.into()),
            location: escape_controls(file),
        }
    }

    /// An error at byte offset `span.start` of `text`, which is the content of `file`.
    pub(crate) fn at_span(
        file: &str,
        text: &str,
        span: Range<usize>,
        message: impl Into<String>,
    ) -> Self {
        let (line, column) = line_col(text, span.start);
        Self::at(file, line, column, message)
    }

    /// The file as given (a path, or `builtin:NAME`).
    pub fn file(&self) -> &str {
        &self.file
    }

    /// 1-based line of the offending value; `None` for errors about the whole file.
    pub fn line(&self) -> Option<usize> {
        self.line
    }

    /// 1-based column (in characters) of the offending value; `None` for errors about
    /// the whole file.
    pub fn column(&self) -> Option<usize> {
        self.column
    }

    /// What is wrong, without the location.
    pub fn message(&self) -> &str {
        &self.message
    }
}

/// `s` with every control character (newline, carriage return, escape, ...) written as
/// its Rust escape (`\n`, `\r`, `\u{1b}`); other text unchanged.
pub fn escape_controls(s: &str) -> String {
    if !s.chars().any(char::is_control) {
        return s.to_owned();
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// The 1-based line and column (counted in characters) of byte `offset` in `text`.
/// An offset past the end, or inside a multi-byte character, is clamped.
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_from_one() {
        let text = "a = 1\nbé = 2\n";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 4), (1, 5));
        assert_eq!(line_col(text, 6), (2, 1));
        // "bé = " is 6 bytes but 5 characters.
        assert_eq!(line_col(text, 12), (2, 6));
        assert_eq!(line_col(text, 1000), (3, 1));
        // Inside the two-byte 'é': clamped back to its start.
        assert_eq!(line_col(text, 8), (2, 2));
    }

    #[test]
    fn control_characters_are_escaped() {
        let e = SceneError::at("a\nb.toml", 1, 2, "unknown field `x\ry`, \u{1b}[2J");
        assert_eq!(
            e.to_string(),
            "a\\nb.toml:1:2: unknown field `x\\ry`, \\u{1b}[2J"
        );
        assert_eq!(e.to_string().lines().count(), 1);
    }

    #[test]
    fn display_has_location() {
        let e = SceneError::at(
            "bad.toml",
            14,
            10,
            "body \"ball\": circle radius must be > 0, got -0.5",
        );
        assert_eq!(
            e.to_string(),
            "bad.toml:14:10: body \"ball\": circle radius must be > 0, got -0.5"
        );
        let e = SceneError::whole_file("x.toml", "cannot read: gone");
        assert_eq!(e.to_string(), "x.toml: cannot read: gone");
        assert_eq!(e.line(), None);
    }
}
