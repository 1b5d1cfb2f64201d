//! pbrt's tokens: bare words (statement keywords, `true`, `false`), quoted strings, numbers
//! and brackets; `#` starts a comment that runs to the end of the line. Every token keeps
//! its line and column (1-based, columns count characters) for messages.

#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    Word(String),
    Str(String),
    Num(f64),
    Open,
    Close,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    pub tok: Tok,
    pub line: u32,
    pub col: u32,
}

impl Tok {
    /// How the token is named in messages.
    pub fn describe(&self) -> String {
        match self {
            Tok::Word(w) => format!("`{w}`"),
            Tok::Str(s) => format!("the string \"{s}\""),
            Tok::Num(x) => format!("the number {x}"),
            Tok::Open => "`[`".into(),
            Tok::Close => "`]`".into(),
        }
    }
}

/// A syntax error: position and message.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntaxError {
    pub line: u32,
    pub col: u32,
    pub msg: String,
}

/// Splits a whole file into tokens.
#[cfg(test)]
pub fn tokenize(text: &str) -> Result<Vec<Token>, SyntaxError> {
    tokenize_within(text, usize::MAX).map(|(tokens, _)| tokens)
}

/// Splits a whole file into tokens, keeping at most `max` of them: the tokens kept and how
/// many the file has (more than kept when it has more than `max`, so that a file whose
/// tokens would not fit in memory is measured without being held).
pub fn tokenize_within(text: &str, max: usize) -> Result<(Vec<Token>, usize), SyntaxError> {
    let mut out = Vec::new();
    let mut total = 0usize;
    let mut keep = |out: &mut Vec<Token>, token: Token| {
        total += 1;
        if out.len() < max {
            out.push(token);
        }
    };
    let mut chars = text.char_indices().peekable();
    let (mut line, mut col) = (1u32, 1u32);
    while let Some(&(i, c)) = chars.peek() {
        let (tl, tc) = (line, col);
        let err = |msg: String| SyntaxError {
            line: tl,
            col: tc,
            msg,
        };
        match c {
            '\n' => {
                chars.next();
                line += 1;
                col = 1;
            }
            c if c.is_whitespace() => {
                chars.next();
                col += 1;
            }
            '#' => {
                while let Some(&(_, c)) = chars.peek() {
                    if c == '\n' {
                        break;
                    }
                    chars.next();
                }
            }
            '[' | ']' => {
                chars.next();
                col += 1;
                keep(
                    &mut out,
                    Token {
                        tok: if c == '[' { Tok::Open } else { Tok::Close },
                        line: tl,
                        col: tc,
                    },
                );
            }
            '"' => {
                chars.next();
                col += 1;
                let mut s = String::new();
                let mut closed = false;
                while let Some((_, c)) = chars.next() {
                    col += 1;
                    match c {
                        '"' => {
                            closed = true;
                            break;
                        }
                        '\n' => {
                            return Err(err(
                                "unterminated string (strings end on their line)".into()
                            ))
                        }
                        '\\' => {
                            let Some((_, e)) = chars.next() else { break };
                            col += 1;
                            s.push(match e {
                                'n' => '\n',
                                't' => '\t',
                                'r' => '\r',
                                'b' => '\u{8}',
                                'f' => '\u{c}',
                                other => other,
                            });
                        }
                        c => s.push(c),
                    }
                }
                if !closed {
                    return Err(err("unterminated string at the end of the file".into()));
                }
                keep(
                    &mut out,
                    Token {
                        tok: Tok::Str(s),
                        line: tl,
                        col: tc,
                    },
                );
            }
            c if c.is_ascii_digit() || c == '-' || c == '+' || c == '.' => {
                let start = i;
                let mut end = i;
                while let Some(&(j, c)) = chars.peek() {
                    if c.is_ascii_alphanumeric() || matches!(c, '-' | '+' | '.') {
                        end = j + c.len_utf8();
                        chars.next();
                        col += 1;
                    } else {
                        break;
                    }
                }
                let word = &text[start..end.max(start + 1)];
                let value: f64 = word
                    .parse()
                    .map_err(|_| err(format!("malformed number `{word}`")))?;
                if !value.is_finite() {
                    return Err(err(format!("number `{word}` is not finite")));
                }
                keep(
                    &mut out,
                    Token {
                        tok: Tok::Num(value),
                        line: tl,
                        col: tc,
                    },
                );
            }
            c if c.is_ascii_alphabetic() || c == '_' => {
                let start = i;
                let mut end = i;
                while let Some(&(j, c)) = chars.peek() {
                    if c.is_ascii_alphanumeric() || c == '_' {
                        end = j + 1;
                        chars.next();
                        col += 1;
                    } else {
                        break;
                    }
                }
                keep(
                    &mut out,
                    Token {
                        tok: Tok::Word(text[start..end].to_string()),
                        line: tl,
                        col: tc,
                    },
                );
            }
            other => {
                return Err(err(format!(
                    "unexpected character `{}`",
                    other.escape_debug()
                )));
            }
        }
    }
    Ok((out, total))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(text: &str) -> Vec<Tok> {
        tokenize(text).unwrap().into_iter().map(|t| t.tok).collect()
    }

    #[test]
    fn tokens_with_positions_and_comments() {
        let t =
            tokenize("Shape \"sphere\" # a comment [ 1\n  \"float radius\" [ -2.5e1 ]").unwrap();
        assert_eq!(t[0].tok, Tok::Word("Shape".into()));
        assert_eq!(t[1].tok, Tok::Str("sphere".into()));
        assert_eq!((t[1].line, t[1].col), (1, 7));
        assert_eq!(t[2].tok, Tok::Str("float radius".into()));
        assert_eq!((t[2].line, t[2].col), (2, 3));
        assert_eq!(t[3].tok, Tok::Open);
        assert_eq!(t[4].tok, Tok::Num(-25.0));
        assert_eq!(t.len(), 6);
    }

    #[test]
    fn numbers_in_every_spelling() {
        assert_eq!(
            toks("1 -2 +3 .5 -.25 1e3 2E-1"),
            [1.0, -2.0, 3.0, 0.5, -0.25, 1000.0, 0.2].map(Tok::Num)
        );
    }

    #[test]
    fn escapes_in_strings() {
        assert_eq!(toks(r#""a\"b\\c\n""#), [Tok::Str("a\"b\\c\n".into())]);
    }

    #[test]
    fn a_limited_tokenization_counts_what_it_does_not_keep() {
        let (kept, total) = tokenize_within("Shape \"sphere\" \"float radius\" [ 2 ]", 2).unwrap();
        assert_eq!((kept.len(), total), (2, 6));
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = tokenize("Shape\n  \"sphere").unwrap_err();
        assert_eq!((e.line, e.col), (2, 3));
        assert!(e.msg.contains("unterminated"));
        let e = tokenize("Translate 1 2 3x").unwrap_err();
        assert_eq!((e.line, e.col), (1, 15));
        assert!(e.msg.contains("malformed number `3x`"), "{}", e.msg);
        let e = tokenize("Scale 1 1 1 @").unwrap_err();
        assert_eq!((e.line, e.col), (1, 13));
    }
}
