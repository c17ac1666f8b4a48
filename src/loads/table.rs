//! Time tables read from text files: two columns (t, value) per line.

use super::TimeFunction;
use crate::math::Real;
use std::path::{Path, PathBuf};

/// A line of a table file that is not two numbers (after the first data line).
#[derive(Clone, Debug, PartialEq)]
pub struct BadLine {
    /// Line number, from 1.
    pub line: usize,
    /// The line, trimmed.
    pub text: String,
}

/// Why a table file could not be read.
#[derive(Debug)]
pub enum TableError {
    /// The file cannot be read.
    Read {
        path: PathBuf,
        error: std::io::Error,
    },
    /// A line after the first data line is not two numbers.
    Line { path: PathBuf, bad: BadLine },
    /// The points do not make a table (none, times not increasing, not finite).
    Table { path: PathBuf, message: String },
}

impl std::fmt::Display for TableError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TableError::Read { path, error } => {
                write!(f, "cannot read '{}': {error}", path.display())
            }
            TableError::Line { path, bad } => write!(
                f,
                "{}:{}: expected two numbers, got '{}'",
                path.display(),
                bad.line,
                bad.text
            ),
            TableError::Table { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for TableError {}

/// The (t, value·scale) points of a table file's text. Columns are separated by commas or
/// white space; a line of numbers may have more than two (the rest are ignored). Empty lines
/// and lines starting with `#` are skipped, and so are lines before the first data line that
/// are not all numbers (a header). Times are not checked here ([`TimeFunction::table`] does).
pub fn parse_table(text: &str, scale: Real) -> Result<Vec<(Real, Real)>, BadLine> {
    let mut pts = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cols: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .collect();
        let parsed: Option<Vec<f64>> = cols.iter().map(|c| c.parse().ok()).collect();
        match parsed.as_deref() {
            Some([t, v, ..]) => pts.push((*t, *v * scale)),
            _ if pts.is_empty() => continue, // header
            _ => {
                return Err(BadLine {
                    line: ln + 1,
                    text: line.to_string(),
                })
            }
        }
    }
    Ok(pts)
}

/// A piecewise-linear [`TimeFunction`] from a table file (see [`parse_table`]), its values
/// multiplied by `scale`. Times in the file's unit (s), values in the file's unit × `scale`.
pub fn read_table(path: &Path, scale: Real) -> Result<TimeFunction, TableError> {
    let text =
        crate::limits::read_text_bounded(path, crate::limits::MAX_TEXT_INPUT).map_err(|error| {
            TableError::Read {
                path: path.to_path_buf(),
                error,
            }
        })?;
    let pts = parse_table(&text, scale).map_err(|bad| TableError::Line {
        path: path.to_path_buf(),
        bad,
    })?;
    TimeFunction::table(pts).map_err(|message| TableError::Table {
        path: path.to_path_buf(),
        message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_comments_and_scale() {
        let pts = parse_table("time, value\n# c\n0, 1\n\n1 2 3\n", 10.0).unwrap();
        assert_eq!(pts, vec![(0.0, 10.0), (1.0, 20.0)]);
        let bad = parse_table("0, 1\n1 2 extra\n", 1.0).unwrap_err();
        assert_eq!((bad.line, bad.text.as_str()), (2, "1 2 extra"));
    }
}
