//! Cypher tokens, each with its line and column.

use super::{Pos, QueryError};

/// One token.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    /// An identifier or keyword as written (keywords are matched case-insensitively).
    Ident(String),
    /// A backtick-quoted name (never a keyword).
    Quoted(String),
    /// An integer literal (unsigned; the parser applies a leading minus).
    Int(u64),
    /// A float literal.
    Float(f64),
    /// A string literal, escapes resolved.
    Str(String),
    /// `$name` or `$0`.
    Param(String),
    /// Punctuation or an operator.
    Sym(&'static str),
    /// End of input.
    Eof,
}

/// A token with its place in the source.
#[derive(Debug, Clone)]
pub(crate) struct Token {
    pub tok: Tok,
    pub pos: Pos,
    /// Byte offsets of the token in the source.
    pub start: usize,
    pub end: usize,
}

const SYMS: &[&str] = &[
    "..", "<>", "!=", "<=", ">=", "=~", "+=", "->", "<-", "(", ")", "[", "]", "{", "}", ",", ".",
    ":", ";", "|", "+", "-", "*", "/", "%", "^", "=", "<", ">",
];

struct Cursor<'a> {
    src: &'a str,
    i: usize,
    line: u32,
    col: u32,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<char> {
        self.src[self.i..].chars().next()
    }
    fn peek2(&self) -> Option<char> {
        let mut it = self.src[self.i..].chars();
        it.next();
        it.next()
    }
    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.i += c.len_utf8();
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }
    /// Letters, digits and underscores from here.
    fn word(&mut self) -> String {
        let mut s = String::new();
        while let Some(ch) = self.peek().filter(|ch| ch.is_alphanumeric() || *ch == '_') {
            s.push(ch);
            self.bump();
        }
        s
    }

    /// A backtick-quoted name starting here; a doubled backtick stands for one.
    fn quoted(&mut self, pos: Pos, unterminated: &'static str) -> Result<String, QueryError> {
        self.bump();
        let mut s = String::new();
        loop {
            match self.bump() {
                None => return Err(syntax(pos, "UnexpectedSyntax", unterminated)),
                Some('`') if self.peek() == Some('`') => {
                    self.bump();
                    s.push('`');
                }
                Some('`') => return Ok(s),
                Some(ch) => s.push(ch),
            }
        }
    }

    fn pos(&self) -> Pos {
        Pos {
            line: self.line,
            col: self.col,
        }
    }
}

fn syntax(pos: Pos, code: &'static str, msg: impl Into<String>) -> QueryError {
    QueryError::syntax(code, msg, Some(pos))
}

/// Splits `src` into tokens. The last token is always [`Tok::Eof`].
pub(crate) fn lex(src: &str) -> Result<Vec<Token>, QueryError> {
    let mut c = Cursor {
        src,
        i: 0,
        line: 1,
        col: 1,
    };
    let mut out = Vec::new();
    loop {
        // whitespace and comments
        loop {
            match c.peek() {
                Some(ch) if ch.is_whitespace() => {
                    c.bump();
                }
                Some('/') if c.peek2() == Some('/') => {
                    while let Some(ch) = c.peek() {
                        if ch == '\n' {
                            break;
                        }
                        c.bump();
                    }
                }
                Some('/') if c.peek2() == Some('*') => {
                    let pos = c.pos();
                    c.bump();
                    c.bump();
                    loop {
                        match c.bump() {
                            None => {
                                return Err(syntax(
                                    pos,
                                    "UnexpectedSyntax",
                                    "unterminated comment",
                                ));
                            }
                            Some('*') if c.peek() == Some('/') => {
                                c.bump();
                                break;
                            }
                            _ => {}
                        }
                    }
                }
                _ => break,
            }
        }
        let pos = c.pos();
        let start = c.i;
        let Some(ch) = c.peek() else {
            out.push(Token {
                tok: Tok::Eof,
                pos,
                start,
                end: start,
            });
            return Ok(out);
        };
        let tok = if ch.is_alphabetic() || ch == '_' {
            Tok::Ident(c.word())
        } else if ch == '`' {
            Tok::Quoted(c.quoted(pos, "unterminated `quoted name`")?)
        } else if ch.is_ascii_digit()
            || (ch == '.' && c.peek2().is_some_and(|d| d.is_ascii_digit()))
        {
            number(&mut c, pos)?
        } else if ch == '\'' || ch == '"' {
            c.bump();
            let mut s = String::new();
            loop {
                match c.bump() {
                    None => {
                        return Err(syntax(
                            pos,
                            "UnexpectedSyntax",
                            "unterminated string literal",
                        ));
                    }
                    Some(q) if q == ch => break,
                    Some('\\') => {
                        let epos = c.pos();
                        match c.bump() {
                            Some('\\') => s.push('\\'),
                            Some('\'') => s.push('\''),
                            Some('"') => s.push('"'),
                            Some('n') => s.push('\n'),
                            Some('t') => s.push('\t'),
                            Some('r') => s.push('\r'),
                            Some('b') => s.push('\u{8}'),
                            Some('f') => s.push('\u{c}'),
                            Some(u @ ('u' | 'U')) => {
                                let n = if u == 'u' { 4 } else { 8 };
                                let mut hex = String::new();
                                for _ in 0..n {
                                    match c.bump() {
                                        Some(h) if h.is_ascii_hexdigit() => hex.push(h),
                                        _ => {
                                            return Err(syntax(
                                                epos,
                                                "InvalidUnicodeLiteral",
                                                "bad \\u escape",
                                            ));
                                        }
                                    }
                                }
                                let cp = u32::from_str_radix(&hex, 16).unwrap_or(0xFFFF_FFFF);
                                match char::from_u32(cp) {
                                    Some(ch) => s.push(ch),
                                    None => {
                                        return Err(syntax(
                                            epos,
                                            "InvalidUnicodeLiteral",
                                            format!("\\u{hex} is not a character"),
                                        ));
                                    }
                                }
                            }
                            _ => {
                                return Err(syntax(
                                    epos,
                                    "UnexpectedSyntax",
                                    "unknown escape in string literal",
                                ));
                            }
                        }
                    }
                    Some(ch) => s.push(ch),
                }
            }
            Tok::Str(s)
        } else if ch == '$' {
            c.bump();
            let s = if c.peek() == Some('`') {
                c.quoted(pos, "unterminated parameter name")?
            } else {
                c.word()
            };
            if s.is_empty() {
                return Err(syntax(
                    pos,
                    "UnexpectedSyntax",
                    "`$` must be followed by a parameter name",
                ));
            }
            Tok::Param(s)
        } else {
            let rest = &src[c.i..];
            let Some(sym) = SYMS.iter().find(|s| rest.starts_with(**s)) else {
                return Err(syntax(
                    pos,
                    "UnexpectedSyntax",
                    format!("unexpected character {ch:?}"),
                ));
            };
            for _ in 0..sym.chars().count() {
                c.bump();
            }
            Tok::Sym(sym)
        };
        out.push(Token {
            tok,
            pos,
            start,
            end: c.i,
        });
    }
}

fn number(c: &mut Cursor<'_>, pos: Pos) -> Result<Tok, QueryError> {
    let start = c.i;
    let rest = &c.src[c.i..];
    let lower2: String = rest
        .chars()
        .take(2)
        .collect::<String>()
        .to_ascii_lowercase();
    if lower2 == "0x" || lower2 == "0o" {
        c.bump();
        c.bump();
        let radix = if lower2 == "0x" { 16 } else { 8 };
        let ds = c.i;
        while c.peek().is_some_and(|ch| ch.is_alphanumeric() || ch == '_') {
            c.bump();
        }
        let digits = &c.src[ds..c.i];
        if digits.is_empty() || !digits.chars().all(|d| d.is_digit(radix)) {
            return Err(syntax(
                pos,
                "InvalidNumberLiteral",
                format!("invalid number literal {:?}", &c.src[start..c.i]),
            ));
        }
        return u64::from_str_radix(digits, radix)
            .map(Tok::Int)
            .map_err(|_| {
                syntax(
                    pos,
                    "IntegerOverflow",
                    format!("integer literal {} is too large", &c.src[start..c.i]),
                )
            });
    }
    let mut is_float = false;
    while c.peek().is_some_and(|d| d.is_ascii_digit()) {
        c.bump();
    }
    if c.peek() == Some('.') && c.peek2().is_some_and(|d| d.is_ascii_digit()) {
        is_float = true;
        c.bump();
        while c.peek().is_some_and(|d| d.is_ascii_digit()) {
            c.bump();
        }
    }
    if matches!(c.peek(), Some('e' | 'E')) {
        let save = (c.i, c.line, c.col);
        c.bump();
        if matches!(c.peek(), Some('+' | '-')) {
            c.bump();
        }
        if c.peek().is_some_and(|d| d.is_ascii_digit()) {
            is_float = true;
            while c.peek().is_some_and(|d| d.is_ascii_digit()) {
                c.bump();
            }
        } else {
            (c.i, c.line, c.col) = save;
        }
    }
    // a number glued to letters (`1a`, `9foo`) is not a number
    if c.peek().is_some_and(|ch| ch.is_alphabetic() || ch == '_') {
        while c.peek().is_some_and(|ch| ch.is_alphanumeric() || ch == '_') {
            c.bump();
        }
        return Err(syntax(
            pos,
            "InvalidNumberLiteral",
            format!("invalid number literal {:?}", &c.src[start..c.i]),
        ));
    }
    let text = &c.src[start..c.i];
    if is_float {
        let f: f64 = text.parse().map_err(|_| {
            syntax(
                pos,
                "InvalidNumberLiteral",
                format!("invalid float literal {text:?}"),
            )
        })?;
        if f.is_infinite() {
            return Err(syntax(
                pos,
                "FloatingPointOverflow",
                format!("float literal {text} is too large"),
            ));
        }
        Ok(Tok::Float(f))
    } else if text.len() > 1 && text.starts_with('0') {
        // legacy octal (`017`)
        u64::from_str_radix(&text[1..], 8)
            .map(Tok::Int)
            .map_err(|_| {
                syntax(
                    pos,
                    "InvalidNumberLiteral",
                    format!("invalid number literal {text:?}"),
                )
            })
    } else {
        text.parse::<u64>().map(Tok::Int).map_err(|_| {
            syntax(
                pos,
                "IntegerOverflow",
                format!("integer literal {text} is too large"),
            )
        })
    }
}
