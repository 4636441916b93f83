//! Tokens with their 1-based character columns.

use super::ExprError;

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    Num(f64),
    Ident(String),
    Plus,
    Minus,
    Star,
    Slash,
    Caret,
    LParen,
    RParen,
    Comma,
    End,
}

impl Tok {
    /// How the token reads in an error message.
    pub(crate) fn describe(&self) -> String {
        match self {
            Tok::Num(v) => format!("number {v}"),
            Tok::Ident(s) => format!("'{s}'"),
            Tok::Plus => "'+'".into(),
            Tok::Minus => "'-'".into(),
            Tok::Star => "'*'".into(),
            Tok::Slash => "'/'".into(),
            Tok::Caret => "'^'".into(),
            Tok::LParen => "'('".into(),
            Tok::RParen => "')'".into(),
            Tok::Comma => "','".into(),
            Tok::End => "end of input".into(),
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Token {
    pub tok: Tok,
    pub column: usize,
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Splits `src` into tokens, ending with [`Tok::End`] at one past the last column.
pub(crate) fn lex(src: &str) -> Result<Vec<Token>, ExprError> {
    let chars: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    let err = |i: usize, message: String| ExprError { column: i + 1, message };
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        let single = match c {
            '+' => Some(Tok::Plus),
            '-' => Some(Tok::Minus),
            '*' => Some(Tok::Star),
            '/' => Some(Tok::Slash),
            '^' => Some(Tok::Caret),
            '(' => Some(Tok::LParen),
            ')' => Some(Tok::RParen),
            ',' => Some(Tok::Comma),
            _ => None,
        };
        if let Some(tok) = single {
            out.push(Token { tok, column: start + 1 });
            i += 1;
            continue;
        }
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let digit_at = |k: usize| chars.get(k).is_some_and(|c| c.is_ascii_digit());
        if c.is_ascii_digit() || (c == '.' && digit_at(i + 1)) {
            // digits [. digits] [(e|E) [+|-] digits]
            while digit_at(i) {
                i += 1;
            }
            if chars.get(i) == Some(&'.') {
                i += 1;
                while digit_at(i) {
                    i += 1;
                }
            }
            let mut ok = true;
            if matches!(chars.get(i), Some('e' | 'E')) {
                i += 1;
                if matches!(chars.get(i), Some('+' | '-')) {
                    i += 1;
                }
                ok = digit_at(i);
                while digit_at(i) {
                    i += 1;
                }
            }
            // A number running straight into letters or another dot is a typo, not two tokens.
            if !ok || chars.get(i).is_some_and(|&c| is_ident_char(c) || c == '.') {
                while chars.get(i).is_some_and(|&c| is_ident_char(c) || c == '.') {
                    i += 1;
                }
                let text: String = chars[start..i.min(start + 40)].iter().collect();
                let hint = if !ok { ": the exponent needs digits" } else { "" };
                return Err(err(start, format!("malformed number '{text}'{hint}")));
            }
            let text: String = chars[start..i].iter().collect();
            let v: f64 = text.parse().map_err(|_| err(start, format!("malformed number '{text}'")))?;
            out.push(Token { tok: Tok::Num(v), column: start + 1 });
            continue;
        }
        if c.is_ascii_alphabetic() || c == '_' {
            while chars.get(i).is_some_and(|&c| is_ident_char(c)) {
                i += 1;
            }
            out.push(Token { tok: Tok::Ident(chars[start..i].iter().collect()), column: start + 1 });
            continue;
        }
        return Err(err(start, format!("unexpected character '{}'", c.escape_debug())));
    }
    out.push(Token { tok: Tok::End, column: chars.len() + 1 });
    Ok(out)
}
