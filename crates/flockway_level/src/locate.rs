//! Finds where a value sits in RON source text, so that errors found after parsing (an unknown
//! road name, a lane out of range) can still point at a line and column.

/// One step of a path into a level: a struct field or a list index.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PathStep {
    /// A named field of a struct (or struct-like enum variant).
    Field(&'static str),
    /// An element of a list or tuple.
    Index(usize),
}

/// A 1-based line and column (in characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Pos {
    /// Line, from 1.
    pub line: usize,
    /// Column in characters, from 1.
    pub col: usize,
}

/// The position of the value at `path`, or of the deepest enclosing value that exists (a missing
/// optional field points at the struct that lacks it).
pub fn locate(src: &str, path: &[PathStep]) -> Pos {
    let mut c = Cursor {
        chars: src.char_indices().collect(),
        i: 0,
        src,
    };
    c.skip_trivia();
    let mut pos = c.pos();
    for step in path {
        c.skip_trivia();
        pos = c.pos();
        // Step over an optional struct or variant name before its parentheses.
        let save = c.i;
        if c.peek().is_some_and(|ch| ch.is_alphabetic() || ch == '_') {
            c.ident();
            c.skip_trivia();
            if c.peek() != Some('(') {
                c.i = save;
                return pos;
            }
        }
        let Some(open) = c.peek() else { return pos };
        if open != '(' && open != '[' {
            return pos;
        }
        c.bump();
        let close = if open == '(' { ')' } else { ']' };
        let found = match step {
            PathStep::Field(name) => c.find_field(name, close),
            PathStep::Index(k) => c.find_index(*k, close),
        };
        if !found {
            return pos;
        }
        c.skip_trivia();
        pos = c.pos();
    }
    pos
}

struct Cursor<'a> {
    chars: Vec<(usize, char)>,
    i: usize,
    src: &'a str,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<char> {
        self.chars.get(self.i).map(|&(_, c)| c)
    }

    fn peek_at(&self, k: usize) -> Option<char> {
        self.chars.get(self.i + k).map(|&(_, c)| c)
    }

    fn bump(&mut self) {
        self.i += 1;
    }

    fn pos(&self) -> Pos {
        let byte = self.chars.get(self.i).map_or(self.src.len(), |&(b, _)| b);
        let before = &self.src[..byte];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |n| n + 1);
        Pos {
            line,
            col: before[line_start..].chars().count() + 1,
        }
    }

    fn skip_trivia(&mut self) {
        loop {
            match (self.peek(), self.peek_at(1)) {
                (Some(c), _) if c.is_whitespace() => self.bump(),
                (Some('/'), Some('/')) => {
                    while self.peek().is_some_and(|c| c != '\n') {
                        self.bump();
                    }
                }
                (Some('#'), Some('!')) => {
                    // An inner attribute such as `#![enable(implicit_some)]`, which saved levels
                    // start with.
                    self.i += 2;
                    self.skip_group();
                }
                (Some('/'), Some('*')) => {
                    // RON block comments nest.
                    let mut depth = 0;
                    while let Some(c) = self.peek() {
                        if c == '/' && self.peek_at(1) == Some('*') {
                            depth += 1;
                            self.i += 2;
                        } else if c == '*' && self.peek_at(1) == Some('/') {
                            depth -= 1;
                            self.i += 2;
                            if depth == 0 {
                                break;
                            }
                        } else {
                            self.bump();
                        }
                    }
                }
                _ => return,
            }
        }
    }

    fn ident(&mut self) -> String {
        let mut s = String::new();
        // Raw identifiers: r#name.
        if self.peek() == Some('r') && self.peek_at(1) == Some('#') {
            self.i += 2;
        }
        while let Some(c) = self.peek().filter(|c| c.is_alphanumeric() || *c == '_') {
            s.push(c);
            self.bump();
        }
        s
    }

    /// Skips one value of any kind.
    fn skip_value(&mut self) {
        self.skip_trivia();
        match self.peek() {
            Some('(' | '[' | '{') => self.skip_group(),
            Some(q @ ('"' | '\'')) => self.skip_quoted(q),
            Some('r') if self.is_raw_string() => self.skip_raw_string(),
            Some(_) => {
                while let Some(c) = self.peek() {
                    if matches!(c, ',' | ')' | ']' | '}' | ':') || c.is_whitespace() {
                        break;
                    }
                    if c == '(' {
                        // A named struct, tuple struct or enum variant: `Name(...)`.
                        self.skip_group();
                        break;
                    }
                    self.bump();
                }
                self.skip_trivia();
                if self.peek() == Some('(') {
                    self.skip_group();
                }
            }
            None => {}
        }
    }

    fn is_raw_string(&self) -> bool {
        if self.peek() != Some('r') {
            return false;
        }
        let mut k = 1;
        while self.peek_at(k) == Some('#') {
            k += 1;
        }
        self.peek_at(k) == Some('"')
    }

    fn skip_raw_string(&mut self) {
        self.bump();
        let mut hashes = 0;
        while self.peek() == Some('#') {
            hashes += 1;
            self.bump();
        }
        self.bump();
        while let Some(c) = self.peek() {
            self.bump();
            if c == '"' && (0..hashes).all(|k| self.peek_at(k) == Some('#')) {
                self.i += hashes;
                return;
            }
        }
    }

    /// Skips a string or char literal opened by `quote`, honouring backslash escapes.
    fn skip_quoted(&mut self, quote: char) {
        self.bump();
        while let Some(c) = self.peek() {
            self.bump();
            if c == '\\' {
                self.bump();
            } else if c == quote {
                return;
            }
        }
    }

    fn skip_group(&mut self) {
        let Some(open) = self.peek() else { return };
        let close = match open {
            '(' => ')',
            '[' => ']',
            _ => '}',
        };
        self.bump();
        loop {
            self.skip_trivia();
            match self.peek() {
                None => return,
                Some(c) if c == close => {
                    self.bump();
                    return;
                }
                Some(',' | ':') => self.bump(),
                Some(_) => self.skip_value(),
            }
        }
    }

    /// Inside a struct body: moves to the value of field `name`.
    fn find_field(&mut self, name: &str, close: char) -> bool {
        loop {
            self.skip_trivia();
            match self.peek() {
                None => return false,
                Some(c) if c == close => return false,
                Some(',') => self.bump(),
                Some(c) if c.is_alphabetic() || c == '_' => {
                    let save = self.i;
                    let field = self.ident();
                    self.skip_trivia();
                    if self.peek() == Some(':') {
                        self.bump();
                        if field == name {
                            return true;
                        }
                        self.skip_value();
                    } else {
                        // Not a field (a tuple of identifiers): skip it as a value.
                        self.i = save;
                        self.skip_value();
                    }
                }
                Some(_) => self.skip_value(),
            }
        }
    }

    /// Inside a list or tuple body: moves to element `k`.
    fn find_index(&mut self, k: usize, close: char) -> bool {
        let mut n = 0;
        loop {
            self.skip_trivia();
            match self.peek() {
                None => return false,
                Some(c) if c == close => return false,
                Some(',') => self.bump(),
                Some(_) => {
                    if n == k {
                        return true;
                    }
                    self.skip_value();
                    n += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use PathStep::{Field, Index};

    const SRC: &str = r#"Level( // a comment with ( and "
    version: 1,
    /* block /* nested */ comment */
    roads: [
        (name: "a,b)", points: [(pos: (0.0, 0.0, 0.0)), (pos: (1.0, 2.0, 3.0))]),
        Road(name: "second", points: []),
    ],
    spawners: [(road: "x", lane: 7)],
)"#;

    #[test]
    fn finds_fields_and_indices() {
        assert_eq!(locate(SRC, &[Field("version")]), Pos { line: 2, col: 14 });
        assert_eq!(
            locate(SRC, &[Field("roads"), Index(1), Field("name")]),
            Pos { line: 6, col: 20 }
        );
        assert_eq!(
            locate(
                SRC,
                &[
                    Field("roads"),
                    Index(0),
                    Field("points"),
                    Index(1),
                    Field("pos")
                ]
            ),
            Pos { line: 5, col: 63 }
        );
        assert_eq!(
            locate(SRC, &[Field("spawners"), Index(0), Field("lane")]),
            Pos { line: 8, col: 34 }
        );
    }

    #[test]
    fn attributes_before_the_level_are_skipped() {
        let src = "#![enable(implicit_some)]\n(\n    version: 1,\n    roads: [(name: \"a\")],\n)";
        assert_eq!(
            locate(src, &[Field("roads"), Index(0), Field("name")]),
            Pos { line: 4, col: 20 }
        );
    }

    #[test]
    fn missing_steps_point_at_the_deepest_existing_value() {
        // No `speed` field in the spawner: point at the spawner.
        assert_eq!(
            locate(SRC, &[Field("spawners"), Index(0), Field("speed")]),
            Pos { line: 8, col: 16 }
        );
        assert_eq!(
            locate(SRC, &[Field("spawners"), Index(5)]),
            Pos { line: 8, col: 15 }
        );
    }
}
