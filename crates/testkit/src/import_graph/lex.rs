//! Rust source as the tokens the import scan reads: identifiers, `::` and single punctuation,
//! each with its line. Comments (doc comments too) are dropped; string, character and number
//! literals become one opaque token each, so a path written in a comment or a string is never
//! seen as code.

/// One token: its text (`"::"`, `"{"`, `"crate"`, …; a literal or a lifetime is `"'lit"`) and
/// the line (from 1) it starts on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Tok {
    /// The text; for a literal or a lifetime the placeholder [`LITERAL`].
    pub text: String,
    /// Whether the token is an identifier or keyword (raw identifiers without their `r#`).
    pub ident: bool,
    /// The line it starts on, from 1.
    pub line: usize,
}

/// The text of every literal and lifetime token.
pub(crate) const LITERAL: &str = "'lit";

impl Tok {
    /// Whether the token's text is `s`.
    pub fn is(&self, s: &str) -> bool {
        self.text == s
    }
}

/// The tokens of `source`. Never fails: an unterminated literal or comment runs to the end.
pub(crate) fn tokens(source: &str) -> Vec<Tok> {
    let mut lexer = Lexer { chars: source.chars().collect(), at: 0, line: 1, out: Vec::new() };
    lexer.run();
    lexer.out
}

struct Lexer {
    chars: Vec<char>,
    at: usize,
    line: usize,
    out: Vec<Tok>,
}

fn ident_start(c: char) -> bool {
    c == '_' || c.is_alphabetic()
}

fn ident_char(c: char) -> bool {
    c == '_' || c.is_alphanumeric()
}

impl Lexer {
    fn peek(&self, ahead: usize) -> Option<char> {
        self.chars.get(self.at + ahead).copied()
    }

    /// Moves on one character, counting lines.
    fn bump(&mut self) {
        if self.peek(0) == Some('\n') {
            self.line += 1;
        }
        self.at += 1;
    }

    fn push(&mut self, text: String, ident: bool, line: usize) {
        self.out.push(Tok { text, ident, line });
    }

    fn run(&mut self) {
        while let Some(c) = self.peek(0) {
            let line = self.line;
            match (c, self.peek(1)) {
                (c, _) if c.is_whitespace() => self.bump(),
                ('/', Some('/')) => self.line_comment(),
                ('/', Some('*')) => self.block_comment(),
                ('"', _) => {
                    self.quoted();
                    self.push(LITERAL.into(), false, line);
                }
                ('\'', _) => {
                    self.quote_or_lifetime();
                    self.push(LITERAL.into(), false, line);
                }
                (c, _) if c.is_ascii_digit() => {
                    self.number();
                    self.push(LITERAL.into(), false, line);
                }
                (c, _) if ident_start(c) => self.word(),
                (':', Some(':')) => {
                    self.at += 2;
                    self.push("::".into(), false, line);
                }
                (c, _) => {
                    self.at += 1;
                    self.push(c.to_string(), false, line);
                }
            }
        }
    }

    fn line_comment(&mut self) {
        while self.peek(0).is_some_and(|c| c != '\n') {
            self.at += 1;
        }
    }

    /// A block comment, nested ones inside it included.
    fn block_comment(&mut self) {
        let mut depth = 0usize;
        while let Some(c) = self.peek(0) {
            match (c, self.peek(1)) {
                ('/', Some('*')) => {
                    depth += 1;
                    self.at += 2;
                }
                ('*', Some('/')) => {
                    self.at += 2;
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        return;
                    }
                }
                _ => self.bump(),
            }
        }
    }

    /// A `"…"` string with escapes, from its opening quote.
    fn quoted(&mut self) {
        self.at += 1;
        while let Some(c) = self.peek(0) {
            match c {
                '\\' => {
                    self.at += 1;
                    self.bump();
                }
                '"' => {
                    self.at += 1;
                    return;
                }
                _ => self.bump(),
            }
        }
    }

    /// A raw string from its first `#` or quote: `#…#"…"#…#`.
    fn raw_string(&mut self) {
        let mut hashes = 0;
        while self.peek(0) == Some('#') {
            hashes += 1;
            self.at += 1;
        }
        self.at += 1; // the opening quote
        while let Some(c) = self.peek(0) {
            self.bump();
            if c == '"' && (0..hashes).all(|k| self.peek(k) == Some('#')) {
                self.at += hashes;
                return;
            }
        }
    }

    /// A character literal (`'x'`, `'\n'`, `'\u{41}'`) or a lifetime or label (`'a`).
    fn quote_or_lifetime(&mut self) {
        self.at += 1;
        match (self.peek(0), self.peek(1)) {
            (Some('\\'), _) => {
                self.at += 2;
                while self.peek(0).is_some_and(|c| c != '\'' && c != '\n') {
                    self.at += 1;
                }
                if self.peek(0) == Some('\'') {
                    self.at += 1;
                }
            }
            (Some(_), Some('\'')) => self.at += 2,
            _ => {
                while self.peek(0).is_some_and(ident_char) {
                    self.at += 1;
                }
            }
        }
    }

    /// A number: digits, letters (suffixes, hex, exponents), `_`, and a `.` followed by a digit.
    fn number(&mut self) {
        while let Some(c) = self.peek(0) {
            let decimal_point = c == '.' && self.peek(1).is_some_and(|d| d.is_ascii_digit());
            if !(ident_char(c) || decimal_point) {
                return;
            }
            self.at += 1;
        }
    }

    /// An identifier or keyword, or a prefixed literal (`b"…"`, `r#"…"#`, `b'x'`, `c"…"`), or
    /// a raw identifier (`r#type`, read as `type`).
    fn word(&mut self) {
        let line = self.line;
        let start = self.at;
        while self.peek(0).is_some_and(ident_char) {
            self.at += 1;
        }
        let word: String = self.chars.get(start..self.at).unwrap_or_default().iter().collect();
        let (next, after) = (self.peek(0), self.peek(1));
        let raw_prefix = matches!(word.as_str(), "r" | "br" | "cr");
        if raw_prefix && (next == Some('"') || (next == Some('#') && matches!(after, Some('"' | '#')))) {
            self.raw_string();
            self.push(LITERAL.into(), false, line);
        } else if word == "r" && next == Some('#') && after.is_some_and(ident_start) {
            self.at += 1;
            self.word();
        } else if matches!(word.as_str(), "b" | "c") && next == Some('"') {
            self.quoted();
            self.push(LITERAL.into(), false, line);
        } else if word == "b" && next == Some('\'') {
            self.quote_or_lifetime();
            self.push(LITERAL.into(), false, line);
        } else {
            self.push(word, true, line);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(source: &str) -> Vec<String> {
        tokens(source).into_iter().map(|t| t.text).collect()
    }

    #[test]
    fn comments_and_literals_hide_what_they_hold() {
        let t = texts("a // crate::x\n/* b /* nested */ crate::y */ c \"crate::z\" r#\"crate::w\"# 'x' '\\'' 'a");
        assert_eq!(t, ["a", "c", LITERAL, LITERAL, LITERAL, LITERAL, LITERAL]);
    }

    #[test]
    fn paths_punctuation_numbers_and_lines() {
        let toks = tokens("use crate::a::{b, c};\nlet x = 1.5e3 + 0..2;\nr#type b'\\n' br\"q\"");
        let t: Vec<_> = toks.iter().map(|t| t.text.as_str()).collect();
        assert_eq!(
            t,
            [
                "use", "crate", "::", "a", "::", "{", "b", ",", "c", "}", ";", "let", "x", "=", LITERAL, "+", LITERAL,
                ".", ".", LITERAL, ";", "type", LITERAL, LITERAL
            ]
        );
        assert_eq!(toks.iter().map(|t| t.line).max(), Some(3));
        assert_eq!(toks.iter().find(|t| t.is("let")).map(|t| t.line), Some(2));
    }

    #[test]
    fn unterminated_input_ends_without_panic() {
        for s in ["\"abc", "/* x", "r#\"x", "'", "b'", "r#", "a::"] {
            let _ = tokens(s);
        }
    }
}
