//! Scene-file errors, each naming the file, line and column, the key and what is wrong.

use std::fmt;
use std::ops::Range;

/// Where in a scene file an error is: the file, and the line and column when known.
///
/// Displays as `file:line:column` (1-based), or just `file` for errors that have no position.
/// [`Location::snippet`] gives the offending source line with a caret under the span.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The file as the user named it.
    pub file: String,
    /// 1-based line, 0 when unknown.
    pub line: usize,
    /// 1-based column in characters, 0 when unknown.
    pub column: usize,
    /// The source line the error is on (empty when unknown).
    pub source_line: String,
    /// Length of the marked span on that line, in characters (at least 1 when known).
    pub width: usize,
}

impl Location {
    /// A location with no position in the file.
    pub fn file_only(file: &str) -> Self {
        Self {
            file: file.to_string(),
            line: 0,
            column: 0,
            source_line: String::new(),
            width: 0,
        }
    }

    /// The location of byte range `span` of `text`.
    pub fn of_span(file: &str, text: &str, span: Range<usize>) -> Self {
        let start = floor_char_boundary(text, span.start.min(text.len()));
        let end = floor_char_boundary(text, span.end.clamp(start, text.len()));
        let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let line = text[..start].matches('\n').count() + 1;
        let column = text[line_start..start].chars().count() + 1;
        let source_line = text[line_start..line_end]
            .trim_end_matches('\r')
            .to_string();
        let width = text[start..end.min(line_end)].chars().count().max(1);
        Self {
            file: file.to_string(),
            line,
            column,
            source_line,
            width,
        }
    }

    /// The source line with a caret line under the span, indented and preceded by a newline;
    /// empty when the location has no line.
    pub fn snippet(&self) -> String {
        if self.line == 0 {
            return String::new();
        }
        let number = self.line.to_string();
        let pad = " ".repeat(number.len());
        format!(
            "\n{pad} |\n{number} | {}\n{pad} | {}{}",
            self.source_line,
            " ".repeat(self.column - 1),
            "^".repeat(self.width)
        )
    }
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file)
        } else {
            write!(f, "{}:{}:{}", self.file, self.line, self.column)
        }
    }
}

fn did_you_mean(suggestion: &Option<String>) -> String {
    suggestion
        .as_ref()
        .map(|s| format!("; did you mean `{s}`?"))
        .unwrap_or_default()
}

/// An error reading a scene file. The message names the file, line and column, the key, the
/// value and what is allowed, followed by the source line with a caret under the culprit.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read the scene file: {source}")]
    Read {
        /// The path as given.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not valid TOML.
    #[error("{at}: TOML syntax error: {message}{}", at.snippet())]
    Syntax {
        /// Where.
        at: Box<Location>,
        /// The parser's message.
        message: String,
    },
    /// A key that the scene format does not have.
    #[error(
        "{at}: unknown key `{key}`{}\n  valid keys here: {}{}",
        did_you_mean(suggestion),
        valid.join(", "),
        at.snippet()
    )]
    UnknownKey {
        /// Where.
        at: Box<Location>,
        /// Full key path, e.g. `cloth.masss`.
        key: String,
        /// The closest valid key at the same place, or a key path elsewhere with that name.
        suggestion: Option<String>,
        /// The valid keys at that place.
        valid: Vec<String>,
    },
    /// A value of the wrong type (a string where a number is expected, ...).
    #[error("{at}: {key} = {value} has the wrong type: {message}{}", at.snippet())]
    WrongType {
        /// Where.
        at: Box<Location>,
        /// Full key path.
        key: String,
        /// The value as written in the file.
        value: String,
        /// What was expected.
        message: String,
    },
    /// A required key is missing.
    #[error("{at}: `{key}` is missing: {message}{}", at.snippet())]
    Missing {
        /// Where (the table that lacks the key).
        at: Box<Location>,
        /// Full key path.
        key: String,
        /// What the key means and how to write it.
        message: String,
    },
    /// A value outside its allowed range.
    #[error("{at}: {key} = {value} is out of range: allowed {range}{}", at.snippet())]
    OutOfRange {
        /// Where.
        at: Box<Location>,
        /// Full key path, e.g. `cloth.mass` or `collider[0].friction`.
        key: String,
        /// The value.
        value: String,
        /// The allowed range, in words.
        range: String,
    },
    /// A value that is invalid for another reason (an unknown shape or integrator name, ...).
    #[error("{at}: {key} = {value}: {message}{}", at.snippet())]
    Invalid {
        /// Where.
        at: Box<Location>,
        /// Full key path.
        key: String,
        /// The value as written in the file (or as resolved, for a default).
        value: String,
        /// What is wrong and what is allowed.
        message: String,
    },
}

impl SceneError {
    /// The location in the file, if the error has one.
    pub fn location(&self) -> Option<&Location> {
        match self {
            SceneError::Read { .. } => None,
            SceneError::Syntax { at, .. }
            | SceneError::UnknownKey { at, .. }
            | SceneError::WrongType { at, .. }
            | SceneError::Missing { at, .. }
            | SceneError::OutOfRange { at, .. }
            | SceneError::Invalid { at, .. } => Some(at.as_ref()),
        }
    }

    /// The same error, said to come from `at` instead of where it was found (errors in a
    /// scene rewritten by [`crate::Scene::set`] are placed at the change, not at a line of the
    /// rewritten text). A read error keeps its path.
    pub fn placed(mut self, place: Location) -> Self {
        match &mut self {
            SceneError::Read { .. } => {}
            SceneError::Syntax { at, .. }
            | SceneError::UnknownKey { at, .. }
            | SceneError::WrongType { at, .. }
            | SceneError::Missing { at, .. }
            | SceneError::OutOfRange { at, .. }
            | SceneError::Invalid { at, .. } => **at = place,
        }
        self
    }

    /// The value the error is about, as written, if any.
    pub fn value(&self) -> Option<&str> {
        match self {
            SceneError::WrongType { value, .. }
            | SceneError::OutOfRange { value, .. }
            | SceneError::Invalid { value, .. } => Some(value),
            _ => None,
        }
    }

    /// The key path the error is about, if any.
    pub fn key(&self) -> Option<&str> {
        match self {
            SceneError::Read { .. } | SceneError::Syntax { .. } => None,
            SceneError::UnknownKey { key, .. }
            | SceneError::WrongType { key, .. }
            | SceneError::Missing { key, .. }
            | SceneError::OutOfRange { key, .. }
            | SceneError::Invalid { key, .. } => Some(key),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_map_to_one_based_lines_and_columns() {
        let text = "a = 1\n[cloth]\nmass = -1\n";
        let at = Location::of_span("s.toml", text, 21..23);
        assert_eq!((at.line, at.column, at.width), (3, 8, 2));
        assert_eq!(at.to_string(), "s.toml:3:8");
        assert_eq!(at.snippet(), "\n  |\n3 | mass = -1\n  |        ^^");
        assert_eq!(Location::file_only("s.toml").to_string(), "s.toml");
    }
}
