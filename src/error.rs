//! Errors and their exit codes: 2 for bad input (a shot, an argument), 1 for a failure
//! while baking. Nothing in the tool panics on bad input.

use std::fmt;
use std::path::PathBuf;

/// A problem in a shot file, located precisely enough for an artist to fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct ShotError {
    pub file: PathBuf,
    /// 1-based line and column; 0 when the problem has no place in the file.
    pub line: usize,
    pub column: usize,
    /// Dotted key path, e.g. `swarm[0].count`; empty when not about one key.
    pub key: String,
    pub message: String,
    /// The offending source line, shown under the message.
    pub source_line: Option<String>,
    pub hint: Option<String>,
}

impl fmt::Display for ShotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        write!(f, ": ")?;
        if !self.key.is_empty() {
            write!(f, "key `{}`: ", self.key)?;
        }
        write!(f, "{}", self.message)?;
        if let Some(src) = &self.source_line {
            let gutter = self.line.to_string();
            write!(f, "\n {gutter} | {src}")?;
            let pad = " ".repeat(gutter.len());
            let col = self.column.max(1) - 1;
            // Column counts characters; tabs keep their width so the caret lines up.
            let lead: String = src
                .chars()
                .take(col)
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            write!(f, "\n {pad} | {lead}^")?;
        }
        if let Some(h) = &self.hint {
            write!(f, "\n  hint: {h}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ShotError {}

/// Every error the tool reports.
#[derive(Debug)]
pub enum Error {
    /// The shot is wrong: exit code 2.
    Shot(Box<ShotError>),
    /// A command-line argument or other input is wrong: exit code 2.
    Input(String),
    /// Baking or writing failed: exit code 1.
    Bake(String),
}

impl Error {
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Shot(_) | Error::Input(_) => 2,
            Error::Bake(_) => 1,
        }
    }
    pub fn bake(msg: impl Into<String>) -> Self {
        Error::Bake(msg.into())
    }
    pub fn input(msg: impl Into<String>) -> Self {
        Error::Input(msg.into())
    }
    /// A filesystem error while writing `path`.
    pub fn io(path: &std::path::Path, e: std::io::Error) -> Self {
        Error::Bake(format!("cannot write {}: {e}", path.display()))
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Shot(e) => write!(f, "{e}"),
            Error::Input(m) | Error::Bake(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for Error {}

impl From<ShotError> for Error {
    fn from(e: ShotError) -> Self {
        Error::Shot(Box::new(e))
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
