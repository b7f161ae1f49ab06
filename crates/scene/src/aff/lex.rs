//! The AFF tokenizer and a cursor over one file's tokens that reads numbers, counts and
//! words with errors naming the file and line.

use crate::error::SceneError;
use geom::Vec3;
use std::path::Path;

pub(super) struct Tok {
    text: String,
    line: usize,
}

pub(super) fn tokenize(src: &str) -> Vec<Tok> {
    let mut out = Vec::new();
    for (ln, line) in src.lines().enumerate() {
        let line = match line.find(['#', '%']) {
            Some(i) => &line[..i],
            None => line,
        };
        for w in line.split_whitespace() {
            // Braces may be glued to other tokens ("{i", "}").
            let mut rest = w;
            while !rest.is_empty() {
                if let Some(i) = rest.find(['{', '}']) {
                    if i > 0 {
                        out.push(Tok {
                            text: rest[..i].to_string(),
                            line: ln + 1,
                        });
                    }
                    out.push(Tok {
                        text: rest[i..i + 1].to_string(),
                        line: ln + 1,
                    });
                    rest = &rest[i + 1..];
                } else {
                    out.push(Tok {
                        text: rest.to_string(),
                        line: ln + 1,
                    });
                    rest = "";
                }
            }
        }
    }
    out
}

/// A cursor over one file's tokens.
pub(super) struct Cursor<'a> {
    pub(super) toks: &'a [Tok],
    pub(super) pos: usize,
    pub(super) path: &'a Path,
}

impl Cursor<'_> {
    pub(super) fn line(&self) -> usize {
        self.toks
            .get(self.pos)
            .or_else(|| self.toks.last())
            .map_or(1, |t| t.line)
    }
    pub(super) fn err(&self, msg: impl Into<String>) -> SceneError {
        self.err_at(self.line(), msg)
    }
    /// An error at `line` of this file (the line an entity started on).
    pub(super) fn err_at(&self, line: usize, msg: impl Into<String>) -> SceneError {
        SceneError::Parse {
            path: self.path.to_path_buf(),
            line,
            msg: msg.into(),
        }
    }
    pub(super) fn peek(&self) -> Option<&str> {
        self.toks.get(self.pos).map(|t| t.text.as_str())
    }
    pub(super) fn word(&mut self, what: &str) -> Result<String, SceneError> {
        match self.toks.get(self.pos) {
            Some(t) => {
                self.pos += 1;
                Ok(t.text.clone())
            }
            None => Err(self.err(format!("unexpected end of file: expected {what}"))),
        }
    }
    pub(super) fn num(&mut self, what: &str) -> Result<f32, SceneError> {
        let line = self.line();
        let w = self.word(what)?;
        match w.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(SceneError::Parse {
                path: self.path.to_path_buf(),
                line,
                msg: format!("{what}: '{w}' is not finite"),
            }),
            Err(_) => Err(SceneError::Parse {
                path: self.path.to_path_buf(),
                line,
                msg: format!("expected {what} (a number), found '{w}'"),
            }),
        }
    }
    pub(super) fn count(&mut self, what: &str, max: usize) -> Result<usize, SceneError> {
        let line = self.line();
        let w = self.word(what)?;
        match w.parse::<usize>() {
            Ok(n) if n <= max => Ok(n),
            _ => Err(SceneError::Parse {
                path: self.path.to_path_buf(),
                line,
                msg: format!("expected {what} (a count up to {max}), found '{w}'"),
            }),
        }
    }
    /// Room to reserve for `n` items of `tokens` tokens each: no more than the file has
    /// tokens left for (`m vertices 49551616` in a 440-byte file reserved 567 MiB, found by
    /// fuzzing; a count the file cannot back fails when its tokens run out).
    pub(super) fn capacity(&self, n: usize, tokens: usize) -> usize {
        n.min(self.toks.len().saturating_sub(self.pos) / tokens.max(1))
    }
    pub(super) fn vec3(&mut self, what: &str) -> Result<Vec3, SceneError> {
        Ok(Vec3::new(self.num(what)?, self.num(what)?, self.num(what)?))
    }
    pub(super) fn expect(&mut self, w: &str) -> Result<(), SceneError> {
        let line = self.line();
        let got = self.word(&format!("'{w}'"))?;
        if got == w {
            Ok(())
        } else {
            Err(SceneError::Parse {
                path: self.path.to_path_buf(),
                line,
                msg: format!("expected '{w}', found '{got}'"),
            })
        }
    }
    pub(super) fn is_number(&self) -> bool {
        self.peek().is_some_and(|w| w.parse::<f32>().is_ok())
    }
}
