//! Reading a statement's arguments from the tokens: strings, numbers and parameter lists,
//! with the position of each for messages.

use super::lexer::{Tok, Token};
use super::params::{self, Params, Values};
use super::Loc;
use std::path::PathBuf;
use std::sync::Arc;

/// The tokens of one file and the reading position.
pub(super) struct Cursor<'a> {
    pub(super) file: Arc<PathBuf>,
    pub(super) tokens: &'a [Token],
    pub(super) i: usize,
}

impl Cursor<'_> {
    pub(super) fn loc(&self, t: &Token) -> Loc {
        Loc {
            file: self.file.clone(),
            line: t.line,
            col: t.col,
        }
    }

    pub(super) fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.i)
    }

    /// The position just past the last token, for "the file ends here" messages.
    fn end_loc(&self, stmt: &Loc) -> Loc {
        match self.tokens.last() {
            Some(t) => self.loc(t),
            None => stmt.clone(),
        }
    }

    fn next(&mut self, stmt: &Loc, what: &str) -> crate::error::Result<Token> {
        let t = self.tokens.get(self.i).cloned().ok_or_else(|| {
            self.end_loc(stmt)
                .error(format!("the file ends inside {what} (truncated file?)"))
        })?;
        self.i += 1;
        Ok(t)
    }

    pub(super) fn string(&mut self, stmt: &Loc, kw: &str) -> crate::error::Result<String> {
        let t = self.next(stmt, kw)?;
        match &t.tok {
            Tok::Str(s) => Ok(s.clone()),
            other => {
                let loc = self.loc(&t);
                Err(loc.error(format!(
                    "{kw} expects a quoted string, got {}",
                    other.describe()
                )))
            }
        }
    }

    fn numbers(&mut self, stmt: &Loc, kw: &str, n: usize) -> crate::error::Result<Vec<f64>> {
        let bracket = matches!(self.peek().map(|t| &t.tok), Some(Tok::Open));
        if bracket {
            self.i += 1;
        }
        let mut v = Vec::with_capacity(n);
        while v.len() < n {
            let t = self.next(stmt, kw)?;
            match t.tok {
                Tok::Num(x) => v.push(x),
                ref other => {
                    let loc = self.loc(&t);
                    return Err(loc.error(format!(
                        "{kw} takes {n} numbers, got {} after {}",
                        other.describe(),
                        v.len()
                    )));
                }
            }
        }
        if bracket {
            let t = self.next(stmt, kw)?;
            if t.tok != Tok::Close {
                let loc = self.loc(&t);
                return Err(loc.error(format!(
                    "{kw} takes {n} numbers, expected `]`, got {}",
                    t.tok.describe()
                )));
            }
        }
        Ok(v)
    }

    /// `N` numbers, bare or in brackets.
    pub(super) fn array<const N: usize>(
        &mut self,
        stmt: &Loc,
        kw: &str,
    ) -> crate::error::Result<[f64; N]> {
        let v = self.numbers(stmt, kw, N)?;
        Ok(std::array::from_fn(|i| v[i]))
    }

    /// `Option "name" value`: the value token, kept as text.
    pub(super) fn option_value(&mut self) -> Option<String> {
        let t = self.peek()?;
        let v = match &t.tok {
            Tok::Word(w) => w.clone(),
            Tok::Num(x) => x.to_string(),
            _ => return None,
        };
        self.i += 1;
        Some(v)
    }

    /// A parameter list: `"type name" value` or `"type name" [ values ]`, repeated.
    pub(super) fn params(&mut self, stmt: &Loc) -> crate::error::Result<Params> {
        let mut out = Params::default();
        while let Some(t) = self.peek() {
            let Tok::Str(decl) = &t.tok else { break };
            let (decl, dloc) = (decl.clone(), self.loc(t));
            self.i += 1;
            let what = format!("the value of \"{decl}\"");
            let first = self.next(stmt, &what)?;
            let items: Vec<Token> = if first.tok == Tok::Open {
                let mut items = Vec::new();
                loop {
                    let t = self.next(stmt, &format!("the [ ] list of \"{decl}\""))?;
                    match &t.tok {
                        Tok::Close => break,
                        Tok::Open => {
                            let loc = self.loc(&t);
                            return Err(
                                loc.error(format!("unexpected `[` inside the list of \"{decl}\""))
                            );
                        }
                        Tok::Word(w) if w != "true" && w != "false" => {
                            let loc = self.loc(&t);
                            return Err(loc.error(format!(
                                "`{w}` inside the list of \"{decl}\": missing `]`?"
                            )));
                        }
                        _ => items.push(t.clone()),
                    }
                }
                items
            } else {
                vec![first]
            };
            let values = values_of(
                &items,
                &decl,
                &self.loc(&items.first().cloned().unwrap_or(Token {
                    tok: Tok::Close,
                    line: dloc.line,
                    col: dloc.col,
                })),
            )?;
            let param = params::Param::new(&decl, values, dloc.line, dloc.col)
                .map_err(|m| dloc.error(m))?;
            out.list.push(param);
        }
        Ok(out)
    }
}

fn values_of(items: &[Token], decl: &str, loc: &Loc) -> crate::error::Result<Values> {
    let mut nums = Vec::new();
    let mut strs = Vec::new();
    let mut bools = Vec::new();
    for t in items {
        match &t.tok {
            Tok::Num(x) => nums.push(*x),
            Tok::Str(s) => strs.push(s.clone()),
            Tok::Word(w) if w == "true" || w == "false" => bools.push(w == "true"),
            other => {
                return Err(loc.error(format!(
                    "unexpected {} as the value of \"{decl}\"",
                    other.describe()
                )))
            }
        }
    }
    let kinds = [!nums.is_empty(), !strs.is_empty(), !bools.is_empty()];
    if kinds.iter().filter(|&&k| k).count() > 1 {
        return Err(loc.error(format!(
            "the values of \"{decl}\" mix numbers, strings and booleans"
        )));
    }
    Ok(if !strs.is_empty() {
        Values::Strs(strs)
    } else if !bools.is_empty() {
        Values::Bools(bools)
    } else {
        Values::Nums(nums)
    })
}
